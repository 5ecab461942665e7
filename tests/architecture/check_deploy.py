#!/usr/bin/env python3
"""Checks the deployment files under deploy/ (docs/fleet.md).

- deploy/systemd/camlabd.service: `systemd-analyze verify` finds nothing to say about it
  (run on a copy whose ExecStart is the camlabd just built, since verify checks that the
  program exists), and it keeps the hardening docs/fleet.md promises. Prints the exposure
  score `systemd-analyze security` gives it.
- deploy/kubernetes/camlabd-daemonset.yaml: valid YAML; the DaemonSet gets the cameras from
  the device plugin (squat.ai/video), camlabd listens on loopback only (a TLS proxy beside
  it takes the outside), and SIGTERM has time to end the jobs.

Usage: check_deploy.py SOURCE_DIR CAMLABD. Exits 1 naming each problem.
"""
import os
import re
import shutil
import subprocess
import sys
import tempfile

import yaml

HARDENING = ["DynamicUser=yes", "NoNewPrivileges=yes", "ProtectSystem=strict",
             "ProtectHome=yes", "PrivateTmp=yes", "DevicePolicy=closed",
             "DeviceAllow=char-video4linux rw", "CapabilityBoundingSet=",
             "RestrictNamespaces=yes", "SystemCallFilter=@system-service",
             "MemoryDenyWriteExecute=yes", "StateDirectory=camlab"]


def check_unit(root, camlabd, problems):
    unit = os.path.join(root, "deploy", "systemd", "camlabd.service")
    text = open(unit, encoding="utf-8").read()
    for line in HARDENING:
        if not re.search(r"^" + re.escape(line) + r"$", text, re.M):
            problems.append(f"{unit}: no '{line}'")
    analyze = shutil.which("systemd-analyze")
    if not analyze:
        problems.append("systemd-analyze is not installed (scripts/install-deps.sh installs systemd)")
        return
    with tempfile.TemporaryDirectory() as tmp:
        copy = os.path.join(tmp, "camlabd.service")
        with open(copy, "w", encoding="utf-8") as f:
            f.write(text.replace("/usr/local/bin/camlabd", os.path.abspath(camlabd)))
        verify = subprocess.run([analyze, "verify", copy], capture_output=True, text=True,
                                timeout=60)
        said = (verify.stdout + verify.stderr).strip()
        if verify.returncode != 0 or said:
            problems.append(f"systemd-analyze verify {unit}: exit {verify.returncode}: {said}")
        security = subprocess.run([analyze, "security", "--offline=true", copy],
                                  capture_output=True, text=True, timeout=60)
        score = [l for l in security.stdout.splitlines() if "Overall exposure" in l]
        print("systemd-analyze security:", score[0].strip() if score else security.stderr.strip())


def check_daemonset(root, problems):
    path = os.path.join(root, "deploy", "kubernetes", "camlabd-daemonset.yaml")
    try:
        documents = [d for d in yaml.safe_load_all(open(path, encoding="utf-8")) if d]
    except yaml.YAMLError as e:
        problems.append(f"{path}: not YAML: {e}")
        return
    sets = [d for d in documents if d.get("kind") == "DaemonSet"]
    if len(sets) != 1:
        problems.append(f"{path}: {len(sets)} DaemonSets, expected 1")
        return
    pod = sets[0]["spec"]["template"]["spec"]
    camlabd = [c for c in pod["containers"] if c["name"] == "camlabd"]
    if not camlabd:
        problems.append(f"{path}: no container named camlabd")
        return
    args = camlabd[0].get("args", [])
    if "--listen=127.0.0.1:8080" not in args:
        problems.append(f"{path}: camlabd must listen on loopback only (--listen=127.0.0.1:8080)")
    if not any(a.startswith("--db=") for a in args):
        problems.append(f"{path}: camlabd has no --db (the fleet's PostgreSQL)")
    limits = camlabd[0].get("resources", {}).get("limits", {})
    if "squat.ai/video" not in limits:
        problems.append(f"{path}: camlabd requests no squat.ai/video from the device plugin")
    if pod.get("terminationGracePeriodSeconds", 30) < 10:
        problems.append(f"{path}: too little time after SIGTERM to end the jobs")


def main():
    root, camlabd = sys.argv[1], sys.argv[2]
    problems = []
    check_unit(root, camlabd, problems)
    check_daemonset(root, problems)
    for p in problems:
        print(p)
    if problems:
        return 1
    print("deploy/: the systemd unit verifies and the DaemonSet is as docs/fleet.md says")
    return 0


if __name__ == "__main__":
    sys.exit(main())
