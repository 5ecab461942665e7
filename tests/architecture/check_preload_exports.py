#!/usr/bin/env python3
"""Checks what the preload library exports: exactly the libc entry points it interposes.

An LD_PRELOAD library shares the program's symbol namespace, so anything else it exports
(its own C++ classes, the standard library's template instances) could take the place of
the program's own. The entry points are the functions defined in the extern "C" blocks of
the library's sources (mock_device/preload/*.cpp); they must all be exported, and nothing
else.

Usage: check_preload_exports.py LIBRARY.so SOURCE_DIR
"""
import glob
import re
import subprocess
import sys


def interposed_functions(source_path):
    text = open(source_path, encoding="utf-8").read()
    if 'extern "C" {' not in text:
        return set()
    block = text[text.index('extern "C" {'):text.index('}  // extern "C"')]
    # A definition starts a line: return type, name, '('.
    names = re.findall(r"^[A-Za-z_][\w\s\*]*?\b([A-Za-z_]\w*)\s*\([^;{]*\)\s*\{", block, re.M)
    # ... and the aliases: `int open64(...) __attribute__((alias("open")));`
    names += re.findall(r"^[A-Za-z_][\w\s\*]*?\b([A-Za-z_]\w*)\s*\([^;{]*\)\s*__attribute__\(\(alias", block, re.M)
    return set(names)


def main():
    library, source_dir = sys.argv[1], sys.argv[2]
    listed = subprocess.run(["nm", "-D", "--defined-only", library], check=True,
                            capture_output=True, text=True).stdout.split("\n")
    exported = {line.split()[-1] for line in listed if line.strip()}
    expected = set()
    for source in sorted(glob.glob(source_dir + "/mock_device/preload/*.cpp")):
        expected |= interposed_functions(source)
    problems = []
    for name in sorted(exported - expected):
        problems.append(f"exported but not an interposed entry point: {name}")
    for name in sorted(expected - exported):
        problems.append(f"interposed but not exported: {name}")
    for p in problems:
        print(p)
    if problems or len(expected) < 20:
        print(f"{len(problems)} problem(s); {len(expected)} entry points found in the source")
        return 1
    print(f"{len(exported)} symbols exported, exactly the interposed entry points")
    return 0


if __name__ == "__main__":
    sys.exit(main())
