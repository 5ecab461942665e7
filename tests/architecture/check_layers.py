#!/usr/bin/env python3
"""Checks that every #include in camlab follows the arrows of docs/architecture.md.

The link arrows are target_link_libraries; this check covers what linking cannot see: a
header included against the arrows (every target has the whole tree on its include path),
a third-party header in a room that must not see it (Beast outside service/http, SQLite
outside service/store, libpqxx and libpq outside service/store/postgres_*, anything but the
standard library in src/optics).

Usage: check_layers.py SOURCE_DIR. Prints every violation as FILE:LINE: what, and exits 1
when there is one; exits 0 and prints a one-line summary otherwise.
"""
import os
import re
import sys

# Each room: the path prefix of its files, and the rooms (path prefixes of included
# headers, as written in #include "...") it may include. A room may always include itself.
SRC_ALL = ["base/", "optics/", "image/", "analysis/", "device/", "capture/"]
# What every measurement room of src/analysis may use besides image/, optics/ and base/.
ANALYSIS_SHARED = ["analysis/channel_signal.h", "analysis/clip_level.h", "image/", "optics/",
                   "base/"]
ROOMS = [
    # (room prefix in the tree, include prefix of the room itself, allowed include prefixes)
    ("src/base/", "base/", []),
    # src/optics links nothing: only the header-only parts of base/.
    ("src/optics/", "optics/", ["base/result.h", "base/error_code.h", "base/format.h"]),
    ("src/image/", "image/", ["base/"]),
    # The measurements, a room each on the shared edge core and helpers; the dispatch,
    # summary and plots at analysis/'s top see them all (src/analysis/CMakeLists.txt).
    ("src/analysis/edge/", "analysis/edge/", ["image/", "optics/", "base/"]),
    ("src/analysis/defocus/", "analysis/defocus/", ANALYSIS_SHARED + ["analysis/edge/"]),
    ("src/analysis/sfr/", "analysis/sfr/", ANALYSIS_SHARED + ["analysis/edge/"]),
    ("src/analysis/lensmap/", "analysis/lensmap/", ANALYSIS_SHARED + ["analysis/sfr/"]),
    ("src/analysis/exposure/", "analysis/exposure/", ANALYSIS_SHARED),
    ("src/analysis/focus/", "analysis/focus/", ANALYSIS_SHARED),
    ("src/analysis/lightfield/", "analysis/lightfield/", ANALYSIS_SHARED + ["analysis/focus/"]),
    ("src/analysis/", "analysis/", ["image/", "optics/", "base/"]),
    ("src/device/", "device/", ["base/"]),
    ("src/capture/", "capture/", ["device/", "image/", "optics/", "base/"]),
    ("calib/", "calib/", SRC_ALL),
    ("mock_device/spec/", "mock_device/spec/", ["base/", "optics/", "image/"]),
    ("mock_device/render/", "mock_device/render/", ["mock_device/spec/", "base/", "optics/", "image/"]),
    ("mock_device/v4l2/", "mock_device/v4l2/",
     ["mock_device/render/", "mock_device/spec/"] + SRC_ALL),
    ("mock_device/broker/", "mock_device/broker/",
     ["mock_device/v4l2/", "mock_device/render/", "mock_device/spec/"] + SRC_ALL),
    # The preload library runs inside other programs: only the protocol, the header-only
    # sysfs path test and the header-only owners of base/.
    ("mock_device/preload/", "mock_device/preload/",
     ["mock_device/broker/broker_protocol.h", "mock_device/v4l2/fake_sysfs.h",
      "base/unique_fd.h", "base/mapped_buffer.h"]),
    ("service/store/", "service/store/", ["service/log.h", "service/metrics.h"] + SRC_ALL),
    # The live view: what a camera's frames look like on a screen; knows no HTTP and no job.
    ("service/live/", "service/live/", ["service/log.h"] + SRC_ALL),
    ("service/jobs/", "service/jobs/",
     ["service/live/", "service/store/", "service/log.h", "service/metrics.h", "calib/",
      "mock_device/"] + SRC_ALL),
    # The fleet: hosts sharing a PostgreSQL store (through store/'s interfaces only).
    ("service/fleet/", "service/fleet/",
     ["service/jobs/", "service/store/", "service/log.h", "service/metrics.h", "calib/",
      "mock_device/"] + SRC_ALL),
    ("service/api/", "service/api/",
     ["service/fleet/", "service/live/", "service/jobs/", "service/store/", "service/log.h",
      "service/metrics.h", "calib/", "mock_device/"] + SRC_ALL),
    ("service/http/", "service/http/", ["service/api/", "service/log.h"] + SRC_ALL),
    ("service/", "service/", ["calib/", "mock_device/"] + SRC_ALL),
    ("cli/", "cli/", ["calib/", "mock_device/"] + SRC_ALL),
]

# Third-party headers (#include <...>) allowed only in some rooms.
RESTRICTED_SYSTEM = [
    # (header prefix, rooms that may include it, why)
    ("boost/", ["service/http/", "service/daemon.cpp"], "Beast stays in service/http"),
    ("sqlite3.h", ["service/store/"], "SQLite stays in service/store"),
    ("pqxx/", ["service/store/postgres_"], "libpqxx stays in service/store/postgres_*"),
    ("libpq-fe.h", ["service/store/postgres_"], "libpq stays in service/store/postgres_*"),
    ("mrcal", ["calib/", "mock_device/spec/", "mock_device/render/"], "src/ links no mrcal"),
    ("libcamera/", ["src/device/libcamera/"], "libcamera types stay in its backend"),
]

INCLUDE = re.compile(r'^\s*#\s*include\s*([<"])([^>"]+)[>"]')
STANDARD_HEADER = re.compile(r"^[a-z_0-9]+$")  # <cmath>, <string_view>: no '.' and no '/'


def room_of(path):
    for room in ROOMS:
        if path.startswith(room[0]):
            return room
    return None


def check_file(root, path, problems):
    room = room_of(path)
    with open(os.path.join(root, path), encoding="utf-8", errors="replace") as f:
        for number, line in enumerate(f, 1):
            m = INCLUDE.match(line)
            if not m:
                continue
            kind, header = m.groups()
            where = f"{path}:{number}"
            if kind == "<":
                for prefix, allowed, why in RESTRICTED_SYSTEM:
                    if header.startswith(prefix) and not any(path.startswith(a) for a in allowed):
                        problems.append(f"{where}: <{header}> ({why})")
                if path.startswith("src/optics/") and not STANDARD_HEADER.match(header):
                    problems.append(f"{where}: <{header}> (src/optics uses the standard library only)")
                continue
            if room is None or "/" not in header:
                continue  # a header beside the file (cli/commands.h)
            _, own, allowed = room
            if header.startswith(own) or any(header.startswith(a) for a in allowed):
                continue
            problems.append(f"{where}: \"{header}\" is against the arrows of {room[0]}")


def main():
    root = sys.argv[1] if len(sys.argv) > 1 else "."
    problems, count = [], 0
    for top in ["src", "calib", "mock_device", "service", "cli"]:
        for directory, _, files in os.walk(os.path.join(root, top)):
            for name in files:
                if name.endswith((".h", ".cpp")):
                    check_file(root, os.path.relpath(os.path.join(directory, name), root), problems)
                    count += 1
    for p in problems:
        print(p)
    if problems:
        print(f"{len(problems)} include(s) against the arrows in {count} files")
        return 1
    print(f"{count} files: every include follows the arrows")
    return 0


if __name__ == "__main__":
    sys.exit(main())
