#!/usr/bin/env python3
"""The README's camlabd session works when pasted: camlabd starts in the background (and
scripts/run.sh builds first, minutes on a fresh clone), so no line may read the token file
before a line that waits for camlabd to have written it."""
import re
import sys
from pathlib import Path

root = Path(sys.argv[1])
readme = (root / "README.md").read_text()
blocks = re.findall(r"```sh\n(.*?)```", readme, re.S)
session = [b for b in blocks if "camlab-data/token" in b and "curl" in b]
if not session:
    sys.exit("README.md: no shell block with a curl session that reads camlab-data/token")
failures = []
for block in session:
    waited = False
    started = False
    for line in block.splitlines():
        code = line.split("#", 1)[0]
        if re.search(r"(scripts/run\.sh|camlabd)\s*&", code):
            started = True
            waited = False
        if re.search(r"\b(until|while)\b.*camlab-data/token", code):
            waited = True
        elif "camlab-data/token" in code and started and not waited:
            failures.append(line.strip())
if failures:
    for line in failures:
        print(f"README.md: reads the token before waiting for camlabd to write it: {line}")
    sys.exit(1)
print(f"README.md: {len(session)} curl session(s) wait for the token before reading it")
