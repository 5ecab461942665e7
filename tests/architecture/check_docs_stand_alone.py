#!/usr/bin/env python3
"""The documents stand on their own: every relative link in README.md and docs/ resolves
inside the repository, every source path a document names in backquotes exists, and no
file in the tree refers to material outside it.

Usage: check_docs_stand_alone.py SOURCE_DIR
Exit 0 when all hold; otherwise prints each broken reference as file:line and exits 1.
"""
import os
import re
import subprocess
import sys

MARKDOWN_LINK = re.compile(r"\]\(([^)#\s]+)(?:#[^)]*)?\)")
# `path/like/this.cpp` in backquotes, under one of the project's top-level folders.
SOURCE_PATH = re.compile(
    r"`((?:src|calib|cli|service|mock_device|tests|scripts|docs|cmake|deploy)/[A-Za-z0-9_./-]+)`")
# Paths that leave the repository: a parent-directory hop, or an absolute path into a
# developer's machine.
OUTSIDE = re.compile(r"\.\./shared|(?<![\w.])/work/|/home/\w+/")


def tracked_files(root):
    out = subprocess.run(["git", "-C", root, "ls-files"], capture_output=True, text=True)
    if out.returncode != 0:
        # Not a git checkout (a source tarball): walk the tree instead.
        files = []
        for base, dirs, names in os.walk(root):
            dirs[:] = [d for d in dirs if not d.startswith(".") and d != "build"]
            files += [os.path.relpath(os.path.join(base, n), root) for n in names]
        return files
    return out.stdout.split()


def main():
    root = os.path.abspath(sys.argv[1])
    files = tracked_files(root)
    problems = []
    documents = [f for f in files if f.endswith(".md")]
    for doc in documents:
        folder = os.path.dirname(os.path.join(root, doc))
        with open(os.path.join(root, doc), encoding="utf-8") as handle:
            for number, line in enumerate(handle, 1):
                for target in MARKDOWN_LINK.findall(line):
                    if re.match(r"^[a-z]+:", target):  # http:, mailto:
                        continue
                    if not os.path.exists(os.path.normpath(os.path.join(folder, target))):
                        problems.append(f"{doc}:{number}: link to missing {target}")
                for path in SOURCE_PATH.findall(line):
                    path = path.rstrip(".")
                    if any(ch in path for ch in "*{}<>") or path.endswith("/"):
                        if path.endswith("/") and not os.path.isdir(os.path.join(root, path)):
                            problems.append(f"{doc}:{number}: names missing folder {path}")
                        continue
                    if not os.path.exists(os.path.join(root, path)):
                        problems.append(f"{doc}:{number}: names missing file {path}")
    for name in files:
        if name == "tests/architecture/check_docs_stand_alone.py":
            continue
        path = os.path.join(root, name)
        try:
            with open(path, encoding="utf-8") as handle:
                for number, line in enumerate(handle, 1):
                    if OUTSIDE.search(line):
                        problems.append(f"{name}:{number}: refers outside the repository")
        except (UnicodeDecodeError, IsADirectoryError, FileNotFoundError):
            continue
    for problem in problems:
        print(problem)
    if problems:
        print(f"{len(problems)} broken reference(s)")
        return 1
    print(f"{len(documents)} documents checked; all references resolve inside the repository")
    return 0


if __name__ == "__main__":
    sys.exit(main())
