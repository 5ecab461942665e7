#!/usr/bin/python3
# Runs `camlab calibrate --corners` on every case folder written by generate_cases.py and
# checks the result against the truth with mrcal's Python (never camlab's code):
#
#   error vs truth   RMS projection difference over the central 80% of the imager, the
#                    rotation between the two camera frames fitted out (evalcore.py)
#   FOV error        horizontal FOV from the written .cameramodel (edges unprojected by
#                    mrcal) against the truth's; the report's FOV must match the model's
#   fx error         when camlab fitted the truth's own parameterisation
#   warnings         the report's codes (calib/report.h)
#   unc ratio        camlab's reported projection uncertainty over mrcal's at the same
#                    five pixels (median), both at infinity with mrcal's definition; and
#                    whether it covers camlab's actual error there (within 4 sigma)
#
# Verdict per case (case.json "expected", see generate_cases.py):
#   FAIL  camlab failed; a required warning is missing (the data is clearly past camlab's
#         own documented trigger); the report's FOV disagrees with the written model;
#         the result is outside the tolerance and no acceptable warning says so (a silent
#         wrong number); or the data is weak (its 1-sigma error is over a cap), camlab
#         says nothing about it, states an uncertainty under half of mrcal's, and that
#         uncertainty does not cover its actual error at the report's points.
#   PASS  otherwise, with the reason.
# Timing is printed, never judged.
#
# Usage: /usr/bin/python3 run_cases.py CASES_DIR --camlab PATH [--generate] [--subset quick]
#                                      [--only NAME ...]
# Exit: 0 all pass, 1 a failure, 77 no mrcal (ctest's SKIP_RETURN_CODE).

import argparse
import json
import math
import os
import subprocess
import sys
import time

try:
    import numpy as np
    import mrcal
except ImportError:
    print("run_cases: %s has no mrcal (Debian's python3-mrcal is for /usr/bin/python3): skipped" % sys.executable,
          file=sys.stderr)
    sys.exit(77)

HERE = os.path.dirname(os.path.abspath(__file__))
sys.dont_write_bytecode = True  # no __pycache__ in the source tree (ctest runs from it)
sys.path.insert(0, HERE)
import evalcore as ec  # noqa: E402
import generate_cases as gen  # noqa: E402

FOV_REPORT_TOL_DEG = 0.01  # the report's FOV against the same model's FOV computed by mrcal
HONEST_UNCERTAINTY = 0.5   # weak data: camlab's stated uncertainty at least this x mrcal's,
K_COVER = 4.0              # or its actual error within this x its stated 1-sigma at every report point


def run_camlab(camlab, case_dir, case):
    out_model = os.path.join(case_dir, "camlab.cameramodel")
    report = os.path.join(case_dir, "camlab_report.json")
    for p in (out_model, report):
        if os.path.exists(p):
            os.remove(p)
    cmd = [camlab, "calibrate", "--corners", os.path.join(case_dir, case["corners"]),
           "--board", case["board"], "--spacing-m", repr(case["spacing_m"]),
           "--imager", case["imager"], "--model", case["model"],
           "--report", report, "--out", out_model, "--quiet"]
    t0 = time.monotonic()
    p = subprocess.run(cmd, capture_output=True, text=True)
    dt = time.monotonic() - t0
    with open(os.path.join(case_dir, "camlab_stdout.txt"), "w") as f:
        f.write(" ".join(cmd) + "\n\n" + p.stdout + p.stderr)
    return cmd, p, dt, out_model, report


def judge(case, case_dir, p, out_model, report_path):
    """Returns a row dict with the measurements and the verdict."""
    exp = case["expected"]
    row = dict(name=case["name"], model="-", rms=math.nan, err=math.nan, hfov_err=math.nan,
               fx_err=math.nan, unc_ratio=math.nan, warnings=[], verdict="FAIL", reason="")
    if p.returncode != 0:
        last = (p.stderr.strip().splitlines() or ["(no message)"])[-1]
        row["reason"] = "camlab failed (exit %d): %s" % (p.returncode, last)
        return row
    W, H = (int(x) for x in case["imager"].split("x"))
    truth_m = mrcal.cameramodel(os.path.join(case_dir, case["truth"]))
    truth = truth_m.intrinsics()
    with open(report_path) as f:
        rep = json.load(f)
    try:
        fit_m = mrcal.cameramodel(out_model)
    except Exception as e:
        row["reason"] = "mrcal cannot read camlab's .cameramodel: %s" % e
        return row
    fit = fit_m.intrinsics()
    row["model"] = fit[0].replace("LENSMODEL_", "")
    row["rms"] = rep["residuals"]["rms_px"]
    row["warnings"] = [w["code"] for w in rep["warnings"]]
    warnings = set(row["warnings"])
    pts = (rep.get("projection_uncertainty") or {}).get("points") or []
    at = [(pt["x_px"], pt["y_px"]) for pt in pts]
    res = ec.projection_error_px(truth, fit, W, H, at=at if at else None)
    row["err"], row["err_max"], row["rot_deg"] = res[:3]
    err_at = res[3] if at else []
    fov_t = ec.field_of_view_deg(truth, W, H)
    fov_f = ec.field_of_view_parts_deg(fit, W, H)
    if fov_f[0] is not None:
        row["hfov_err"] = abs(fov_f[0] - fov_t[0])
    if fit[0] == truth[0] and "SPLINED" not in fit[0]:
        row["fx_err"] = abs(fit[1][0] / truth[1][0] - 1)
    ref_pts = case["reference"].get("uncertainty_points_px")
    if pts and ref_pts:
        ratios = [pt["at_infinity_px"] / r for pt, r in zip(pts, ref_pts)
                  if pt.get("at_infinity_px") is not None and r > 0]
        if ratios:
            row["unc_ratio"] = float(np.median(ratios))
    # Whether camlab's stated uncertainty covers its actual error at its own report points
    # (centre and image corners; error through the rotation fitted over the central 80%).
    covered = [e <= K_COVER * pt["at_infinity_px"] for e, pt in zip(err_at, pts)
               if pt.get("at_infinity_px") is not None]
    row["uncertainty_covers_error"] = bool(covered) and all(covered)

    problems, notes = [], []
    # The report must describe the model it wrote.
    # Each FOV on its own: the report gives those the model inverts at (a model folding
    # over only in the image corners keeps its horizontal and vertical FOV).
    rep_fov = rep.get("fov_deg") or {}
    for key, mine in zip(("horizontal", "vertical", "diagonal"), fov_f):
        given = rep_fov.get(key)
        if given is not None and mine is not None:
            if abs(given - mine) > FOV_REPORT_TOL_DEG:
                problems.append("report %s FOV differs from the written model's by %.3f deg" %
                                (key, abs(given - mine)))
        elif (given is None) != (mine is None):
            problems.append("report %s FOV %s but mrcal finds it %s" %
                            (key, "missing" if given is None else "given",
                             "defined" if mine is not None else "undefined"))
    missing = [c for c in exp["warn_required"] if c not in warnings]
    if missing:
        problems.append("missing required warning %s (%s)" % (",".join(missing), data_summary(case)))

    # A tolerance of None: the data does not determine that figure at all (mrcal's own
    # optimum leaves it undefined or singular); only the warnings and the stated
    # uncertainty are judged then.
    tol = exp["tol"]
    outside = []
    if tol["err_px"] is not None and not (row["err"] <= tol["err_px"]):
        outside.append("err %.3g > %.3g px" % (row["err"], tol["err_px"]))
    if fov_f[0] is None:
        if "fov_undefined" not in warnings:
            outside.append("FOV undefined")
    elif tol["hfov_deg"] is not None and not (row["hfov_err"] <= tol["hfov_deg"]):
        outside.append("HFOV err %.3g > %.3g deg" % (row["hfov_err"], tol["hfov_deg"]))
    if tol.get("fx_rel") is not None and not math.isnan(row["fx_err"]) and not (row["fx_err"] <= tol["fx_rel"]):
        outside.append("fx err %.2g%% > %.2g%%" % (100 * row["fx_err"], 100 * tol["fx_rel"]))
    # Warnings that the truth contradicts (a false alarm sends the user to recapture or
    # to another model for nothing).
    false = dict(exp.get("warn_false", {}))
    for code, models in exp.get("warn_false_if_fitted", {}).items():
        if fit[0] in models:
            false[code] = "the fitted %s represents the truth %s exactly" % (
                fit[0].replace("LENSMODEL_", ""), truth[0].replace("LENSMODEL_", ""))
    for code in sorted(warnings & set(false)):
        problems.append("false warning %s (%s)" % (code, false[code]))
    warned = sorted(warnings & set(exp["warn_ok"]))
    data_warned = sorted(warnings & set(gen.DATA_WARNINGS))
    extra = sorted(warnings - set(exp["warn_ok"]) - set(exp["warn_required"]))
    if extra:
        notes.append("also warns " + ",".join(extra))

    if problems:
        row["reason"] = "; ".join(problems + outside)
    elif outside:
        if warned:
            row["verdict"] = "PASS"
            row["reason"] = "off truth (%s) but warned %s" % ("; ".join(outside), ",".join(warned))
        else:
            row["reason"] = "silent wrong number: " + "; ".join(outside)
    elif exp["weak"]:
        stated = not math.isnan(row["unc_ratio"]) and row["unc_ratio"] >= HONEST_UNCERTAINTY
        if data_warned or stated or row["uncertainty_covers_error"]:
            row["verdict"] = "PASS"
            row["reason"] = "within what the data supports; weak data (%s) %s" % (
                ",".join(exp["weak"]),
                "warned " + ",".join(data_warned) if data_warned else
                "uncertainty stated" if stated else "stated uncertainty covers the error")
        else:
            row["reason"] = ("weak data (%s: 1-sigma over the cap) with no warning; the stated "
                             "uncertainty is %.2f x mrcal's and does not cover the error (%s px)" % (
                                 ",".join(exp["weak"]), row["unc_ratio"],
                                 "/".join("%.2f" % e for e in err_at)))
    else:
        row["verdict"] = "PASS"
        row["reason"] = "right"
    if notes:
        row["reason"] += " (" + "; ".join(notes) + ")"
    return row


def data_summary(case):
    m = case["data"]
    return "truth: views %d, tilt max %.1f deg off the line of sight and %.1f deg off the image plane, border %.0f%%, span %.2f" % (
        m["views_usable"], m["tilt_max_deg"], m["tilt_axis_max_deg"], 100 * m["border_coverage"], m["span_median"])


def fmt(v, f):
    return "-" if v is None or (isinstance(v, float) and math.isnan(v)) else f % v


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("cases_dir")
    ap.add_argument("--camlab", required=True)
    ap.add_argument("--generate", action="store_true", help="write the cases first (generate_cases.py)")
    ap.add_argument("--subset", choices=["all", "quick"], default="all")
    ap.add_argument("--only", nargs="*", default=[], help="case or dataset names")
    a = ap.parse_args()
    if not os.access(a.camlab, os.X_OK):
        print("run_cases: no camlab at %s" % a.camlab, file=sys.stderr)
        return 1
    names = [name for _, _, name in gen.case_list(a.subset, a.only)]
    if a.generate:
        t0 = time.monotonic()
        os.makedirs(a.cases_dir, exist_ok=True)
        gen.generate_cases(a.cases_dir, a.subset, a.only)
        print("generated %d cases in %.1f s (mrcal's reference solves included)" % (len(names), time.monotonic() - t0))

    rows = []
    hdr = "%-44s %-9s %6s %6s %7s %7s %7s %6s %6s %7s %5s  %-26s %s" % (
        "case", "model", "time_s", "rms_px", "err_px", "ref_px", "tol_px", "hfov_e", "tol", "fx_err%",
        "unc", "warnings", "verdict")
    print(hdr)
    print("-" * len(hdr))
    for name in names:
        d = os.path.join(a.cases_dir, name)
        if not os.path.exists(os.path.join(d, "case.json")):
            print("%-44s missing (run with --generate)" % name)
            rows.append(dict(name=name, verdict="FAIL", reason="case not generated"))
            continue
        with open(os.path.join(d, "case.json")) as f:
            case = json.load(f)
        cmd, p, dt, out_model, report = run_camlab(a.camlab, d, case)
        row = judge(case, d, p, out_model, report)
        row["time_s"] = dt
        row["command"] = " ".join(cmd)
        rows.append(row)
        tol = case["expected"]["tol"]
        print("%-44s %-9s %6.1f %6s %7s %7s %7s %6s %6s %7s %5s  %-26s %s: %s" % (
            name, row["model"][:9], dt, fmt(row["rms"], "%.3f"),
            fmt(row["err"], "%.3f"), fmt(case["reference"]["err_px"], "%.3f"), fmt(tol["err_px"], "%.3f"),
            fmt(row["hfov_err"], "%.3f"), fmt(tol["hfov_deg"], "%.3f"),
            fmt(100 * row["fx_err"] if not math.isnan(row["fx_err"]) else math.nan, "%.3f"),
            fmt(row["unc_ratio"], "%.2f"), ",".join(row["warnings"]) or "-", row["verdict"], row["reason"]),
            flush=True)
    with open(os.path.join(a.cases_dir, "results.json"), "w") as f:
        json.dump(rows, f, indent=2, default=float)
    failed = [r for r in rows if r["verdict"] != "PASS"]
    print("\n%d cases, %d passed, %d failed" % (len(rows), len(rows) - len(failed), len(failed)))
    for r in failed:
        print("FAIL %s: %s\n  %s" % (r["name"], r["reason"], r.get("command", "")))
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
