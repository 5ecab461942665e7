#!/usr/bin/python3
# Writes calibration datasets with a known truth for `camlab calibrate --corners`, made
# with mrcal's own Python (2.2) and nothing of camlab's: for each case a folder with
#
#   corners.vnl          mrcal's corners format (# filename x y [level]), "- - -" rows
#                        for corners off the imager
#   truth.cameramodel    the lens that made the corners (mrcal's writer)
#   case.json            board, imager, camlab's arguments, and what is expected:
#                        tolerances against the truth, warnings that must or may appear
#
# Board poses come from mrcal.synthesize_board_observations, corners are projected with
# mrcal.project; noise, mrgingham-style levels (noise x 2^level, weight 0.5^level), gross
# outliers and off-imager corners are added here with fixed seeds (deterministic).
#
# Tolerances are not tuned to camlab: for every case, mrcal itself solves the same
# observations started from the truth (the optimum near the truth), and again on
# MC_TRIALS re-draws of the noise; the RMS of those solutions' errors against the truth
# is sigma, what the data supports (projection over the central 80% of the imager, the
# horizontal FOV, fx). A result is right when within max(K_SIGMA sigma, FLOOR) of the
# truth. When sigma itself exceeds CAP, the data cannot give a good answer at all: the
# case is "weak", and camlab must say so (a warning, or a stated projection uncertainty
# of at least half of mrcal's: run_cases.py).
#
# Usage: /usr/bin/python3 generate_cases.py OUT_DIR [--subset quick] [--only NAME...]
# Run with /usr/bin/python3: Debian's python3-mrcal is installed for it.

import argparse
import json
import math
import os
import sys
import time
import zlib

try:
    import numpy as np
    import mrcal
except ImportError:
    print("generate_cases: %s has no mrcal (Debian's python3-mrcal is for /usr/bin/python3)" % sys.executable,
          file=sys.stderr)
    sys.exit(77)

sys.dont_write_bytecode = True  # no __pycache__ in the source tree (ctest runs from it)
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import evalcore as ec  # noqa: E402
from cases import BASE, CASES, case_list, model_tag  # noqa: E402
from truth_lenses import make_truth  # noqa: E402

# A result is right when within max(K_SIGMA sigma, FLOOR) of the truth; the data is weak
# when sigma (1-sigma, from MC_TRIALS noise re-draws) exceeds CAP.
K_SIGMA = 4.0
MC_TRIALS = 8
FLOOR = {"err_px": 0.02, "hfov_deg": 0.02, "fx_rel": 0.001}
CAP = {"err_px": 0.1, "hfov_deg": 0.1, "fx_rel": 0.005}
# camlab's documented warning triggers (calib/report.h); a warning is required when the
# truth data is past the trigger by this margin, so a borderline case never decides.
TRIGGER_MARGIN = 0.8
DATA_WARNINGS = ["too_few_views", "fronto_parallel", "centre_only", "far_boards",
                 "many_outliers", "high_residuals", "fov_undefined", "implausible_intrinsics"]


def seed_of(name):
    return zlib.crc32(name.encode()) & 0x7FFFFFFF


# ---- Observations ----------------------------------------------------------------------

def aim_rt(centre):
    """rt of a centre-referenced board whose normal points along the line of sight to
    `centre` (camera frame), rolled so the board's x stays near the camera's x."""
    z = centre / np.linalg.norm(centre)
    x = np.array([1.0, 0, 0]) - z * z[0]
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    R = np.stack((x, y, z), axis=-1)
    return np.concatenate((mrcal.r_from_R(R), centre))


def synthesize(spec, model_truth, rng_seed):
    W, H = spec["imager"]
    cols, rows = spec["board"]
    spacing = spec["spacing"]
    lensmodel, intr = model_truth
    cam = mrcal.cameramodel(intrinsics=(lensmodel, intr), imagersize=(W, H))
    f = intr[0]
    board_w = (cols - 1) * spacing
    # Nominal distance: the board spans `span` of the imager width there (pinhole estimate).
    z0 = f * board_w / (spec["span"] * W)
    fov = ec.field_of_view_deg((lensmodel, intr), W, H)
    half_x = z0 * math.tan(math.radians(min(fov[0], 150) / 2))
    half_y = z0 * math.tan(math.radians(min(fov[1], 150) / 2))
    tilt = math.radians(spec["tilt_deg"])
    which = ("some-cameras-must-see-full-board" if spec["which"] == "full"
             else "some-cameras-must-see-half-board")
    np.random.seed(rng_seed)  # mrcal.synthesize_board_observations draws from numpy's global RNG
    common = dict(object_width_n=cols, object_height_n=rows, object_spacing=spacing,
                  calobject_warp=None, which=which)
    if spec["face"] == "axis":
        q, Rt = mrcal.synthesize_board_observations(
            [cam], rt_ref_boardcenter=np.array([0, 0, 0, 0, 0, z0]),
            rt_ref_boardcenter__noiseradius=np.array([tilt, tilt, math.radians(20),
                                                      half_x * spec["spread"], half_y * spec["spread"],
                                                      z0 * spec["distance_jitter"]]),
            Nframes=spec["views"], **common)
    else:
        # Each board turned to face the line of sight to its centre: one synthesis per
        # view around its own nominal pose.
        qs, Rts = [], []
        rng = np.random.default_rng(rng_seed + 1)
        obj = mrcal.ref_calibration_object(cols, rows, spacing) - \
            np.array([(cols - 1) * spacing / 2, (rows - 1) * spacing / 2, 0])
        need = cols * rows if spec["which"] == "full" else cols * rows // 2 + 1
        for _ in range(100000):
            if len(qs) == spec["views"]:
                break
            c = np.array([rng.uniform(-1, 1) * half_x * spec["spread"],
                          rng.uniform(-1, 1) * half_y * spec["spread"],
                          z0 * (1 + spec["distance_jitter"] * rng.uniform(-1, 1))])
            rt = aim_rt(c)
            # The nominal pose must show the board (2% inside the edges), or mrcal's
            # synthesis, which only re-draws the small tilt noise, would never finish.
            qc = mrcal.project(mrcal.transform_point_rt(rt, obj), lensmodel, intr)
            inside = ((qc[..., 0] > 0.02 * W) & (qc[..., 0] < 0.98 * W) &
                      (qc[..., 1] > 0.02 * H) & (qc[..., 1] < 0.98 * H))
            if np.count_nonzero(inside) < need:
                continue
            qi, Rti = mrcal.synthesize_board_observations(
                [cam], rt_ref_boardcenter=rt,
                rt_ref_boardcenter__noiseradius=np.array([tilt, tilt, tilt, 0, 0, 0]),
                Nframes=1, **common)
            qs.append(qi)
            Rts.append(Rti)
        q, Rt = np.concatenate(qs), np.concatenate(Rts)
    q = q[:, 0]  # (views, rows, cols, 2)
    return q, mrcal.rt_from_Rt(Rt)


def visible_mask(q, spec, model_truth, rt_board):
    """Corners a real camera would report: in front of the camera, inside the imager, and
    not beyond a polynomial model's fold (their pixel must unproject back to them)."""
    W, H = spec["imager"]
    cols, rows = spec["board"]
    obj = mrcal.ref_calibration_object(cols, rows, spec["spacing"])  # (rows, cols, 3)
    p = mrcal.transform_point_rt(rt_board[:, None, None, :], obj)    # (views, rows, cols, 3)
    mask = (q[..., 0] >= 0) & (q[..., 0] <= W - 1) & (q[..., 1] >= 0) & (q[..., 1] <= H - 1)
    mask &= p[..., 2] > 0
    v = ec.unit(p)
    flat_q = np.ascontiguousarray(q.reshape(-1, 2))
    with np.errstate(all="ignore"):
        back = ec.unit(mrcal.unproject(flat_q, *model_truth)).reshape(v.shape)
    cosang = np.sum(back * v, axis=-1)
    mask &= np.isfinite(cosang) & (cosang > math.cos(1e-6 * 50))
    return mask


def corrupt(q, mask, spec, rng):
    """Levels (mrgingham-style, 0/1/2 at 70/20/10%), gross outliers (a share of the
    visible corners moved 5-40 px in a random direction) and the Gaussian noise's scale
    (sigma x 2^level per coordinate). Returns (levels, outlier flags, outlier shifts,
    per-corner sigma); add_noise() makes one noisy observation from them."""
    levels = np.zeros(q.shape[:-1], dtype=int)
    if spec["levels"]:
        u = rng.uniform(size=levels.shape)
        levels[u > 0.7] = 1
        levels[u > 0.9] = 2
    sigma = spec["noise_px"] * (2.0 ** levels)
    outlier = np.zeros(levels.shape, dtype=bool)
    shift = np.zeros(q.shape)
    if spec["outliers"] > 0:
        idx = np.argwhere(mask)
        n = int(round(spec["outliers"] * len(idx)))
        for i, j, k in idx[rng.choice(len(idx), size=n, replace=False)]:
            a = rng.uniform(0, 2 * math.pi)
            shift[i, j, k] = rng.uniform(5, 40) * np.array([math.cos(a), math.sin(a)])
            outlier[i, j, k] = True
    return levels, outlier, shift, sigma


def add_noise(q, shift, sigma, rng):
    return q + rng.normal(size=q.shape) * sigma[..., None] + shift


def write_vnl(path, qn, mask, levels, spec):
    W, H = spec["imager"]
    with open(path, "w") as f:
        f.write("# filename x y level\n" if spec["level_column"] else "# filename x y\n")
        for e in range(spec["empty_images"]):
            # mrgingham lists an image without a board as one "- - -" row.
            f.write("empty%03d.png - -%s\n" % (e, " -" if spec["level_column"] else ""))
        for i in range(qn.shape[0]):
            name = "frame%03d.png" % i
            for j in range(qn.shape[1]):
                for k in range(qn.shape[2]):
                    if not mask[i, j, k]:
                        f.write("%s - -%s\n" % (name, " -" if spec["level_column"] else ""))
                    elif spec["level_column"]:
                        f.write("%s %.6f %.6f %d\n" % (name, qn[i, j, k, 0], qn[i, j, k, 1], levels[i, j, k]))
                    else:
                        f.write("%s %.6f %.6f\n" % (name, qn[i, j, k, 0], qn[i, j, k, 1]))


# ---- What the data supports -------------------------------------------------------------

def data_metrics(spec, q_true, mask, rt_board):
    """camlab's warning metrics (calib/report.cpp) computed from the truth: views with 8+
    corners, largest board tilt off the line of sight, border coverage of a 16 x 10 cell
    grid, median board span over the imager diagonal. And the largest tilt off the image
    plane (board normal against the optical axis): boards parallel to the image plane map
    by a similarity wherever they are, so focal length and distance trade off exactly
    (the degeneracy the fronto_parallel warning describes)."""
    W, H = spec["imager"]
    cols, rows = spec["board"]
    used = [i for i in range(len(mask)) if np.count_nonzero(mask[i]) >= 8]
    tilts, tilts_axis, spans = [], [], []
    cells = np.zeros((10, 16), dtype=bool)
    for i in used:
        R = mrcal.R_from_r(rt_board[i, :3])
        n = R[:, 2]
        centre = R @ np.array([0.5 * (cols - 1) * spec["spacing"], 0.5 * (rows - 1) * spec["spacing"], 0]) + rt_board[i, 3:]
        tilts.append(math.degrees(math.acos(min(1.0, abs(float(n @ centre) / np.linalg.norm(centre))))))
        tilts_axis.append(math.degrees(math.acos(min(1.0, abs(float(n[2]))))))
        qi = q_true[i][mask[i]]
        spans.append(math.hypot(*(qi.max(axis=0) - qi.min(axis=0))) / math.hypot(W, H))
        gx = np.clip((qi[:, 0] / W * 16).astype(int), 0, 15)
        gy = np.clip((qi[:, 1] / H * 10).astype(int), 0, 9)
        cells[gy, gx] = True
    ring = np.ones((10, 16), dtype=bool)
    ring[1:-1, 1:-1] = False
    return dict(views_usable=len(used), tilt_max_deg=max(tilts) if tilts else 0.0,
                tilt_axis_max_deg=max(tilts_axis) if tilts_axis else 0.0,
                border_coverage=float(np.count_nonzero(cells & ring)) / np.count_nonzero(ring),
                span_median=float(np.median(spans)) if spans else 0.0)


class quiet_stderr:
    """Silences file descriptor 2 (mrcal's C code reports each outlier pass there)."""
    def __enter__(self):
        sys.stderr.flush()
        self.saved = os.dup(2)
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, 2)
        os.close(devnull)

    def __exit__(self, *exc):
        os.dup2(self.saved, 2)
        os.close(self.saved)


def reference_solve(lensmodel, intr_seed, rt_board, qn, mask, levels, outlier_flags, spec):
    # outlier_flags are not given to mrcal: its own outlier rejection must find them.
    """mrcal.optimize on the same observations, started at the truth (so it finds the
    optimum near the truth), with mrcal's regularization, outlier rejection and board
    warp as camlab uses them. Returns the optimization inputs after the solve."""
    W, H = spec["imager"]
    weight = np.where(mask, 0.5 ** levels, -1.0)
    obs = np.concatenate((qn, weight[..., None]), axis=-1)
    keep = [i for i in range(len(mask)) if np.count_nonzero(mask[i]) >= 8]
    inputs = dict(
        intrinsics=np.array([intr_seed], dtype=float),
        extrinsics_rt_fromref=np.zeros((0, 6)),
        frames_rt_toref=np.ascontiguousarray(rt_board[keep]),
        points=None,
        observations_board=np.ascontiguousarray(obs[keep]),
        indices_frame_camintrinsics_camextrinsics=np.array([[i, 0, -1] for i in range(len(keep))], dtype=np.int32),
        observations_point=None,
        indices_point_camintrinsics_camextrinsics=None,
        lensmodel=lensmodel,
        imagersizes=np.array([[W, H]], dtype=np.int32),
        calobject_warp=np.zeros(2),
        do_optimize_intrinsics_core=True,
        do_optimize_intrinsics_distortions=True,
        do_optimize_extrinsics=True,  # no extrinsics exist (one camera); mrcal's uncertainty wants it set
        do_optimize_frames=True,
        do_optimize_calobject_warp=True,
        calibration_object_spacing=spec["spacing"],
        do_apply_outlier_rejection=True,
        do_apply_regularization=True,
        verbose=False)
    with quiet_stderr():
        mrcal.optimize(**inputs)
    return inputs


def reference_errors(truth, lensmodel, inputs, spec):
    """Errors of a reference solution against the truth: projection (px RMS, central 80%,
    rotation fitted), horizontal FOV (deg), fx (relative; only when the parameterisation
    is the truth's)."""
    W, H = spec["imager"]
    intr = inputs["intrinsics"][0]
    err = ec.projection_error_px(truth, (lensmodel, intr), W, H)[0]
    ft = ec.field_of_view_deg(truth, W, H)
    fr = ec.field_of_view_deg((lensmodel, intr), W, H)
    hfov = abs(fr[0] - ft[0]) if ft and fr else math.inf
    # A splined model's core fx trades with its spline surface: not a lens property.
    fx = abs(intr[0] / truth[1][0] - 1) if lensmodel == truth[0] and "SPLINED" not in lensmodel else math.nan
    return err, hfov, fx


def uncertainty_points(inputs, spec, sigma_px):
    """mrcal's projection uncertainty (worst direction, 1 sigma, at infinity, with the
    known noise) at camlab's report points (calib/uncertainty.cpp summarize_uncertainty):
    the centre and the four corner pixels. camlab states its uncertainty with mrcal's
    definition, so these are comparable to its report. None when J^T J is singular."""
    W, H = spec["imager"]
    lensmodel, intr = inputs["lensmodel"], inputs["intrinsics"][0]
    w, h = W - 1, H - 1
    qp = np.array([[0.5 * w, 0.5 * h], [0, 0], [w, 0], [0, h], [w, h]], dtype=float)
    try:
        model = mrcal.cameramodel(optimization_inputs=inputs, icam_intrinsics=0)
        vp = mrcal.unproject(qp, lensmodel, intr)
        s = mrcal.projection_uncertainty(vp, model, atinfinity=True, what="worstdirection-stdev",
                                         observed_pixel_uncertainty=sigma_px)
        return [float(x) for x in s]
    except Exception:
        return None


def expected_for(spec, model, truth, metrics, spread):
    """Tolerances (K_SIGMA x the Monte-Carlo spread, at least FLOOR), the metrics whose
    spread passes CAP ("weak": the data cannot give a good answer), and
    the warnings that must (documented trigger clearly met) or may (the case's hard
    feature) appear."""
    tol, weak = {}, []
    for key in ("err_px", "hfov_deg", "fx_rel"):
        want = K_SIGMA * spread[key]
        tol[key] = float(max(want, FLOOR[key])) if math.isfinite(want) else None
        if not (spread[key] <= CAP[key]):
            weak.append(key)
    if not math.isfinite(spread["fx_rel"]) and "fx_rel" in weak:
        weak.remove("fx_rel")  # not comparable (another parameterisation)
        tol["fx_rel"] = None
    required = []
    if metrics["views_usable"] < 8:
        required.append("too_few_views")
    # fronto_parallel: required when every board is near the image plane (the physical
    # degeneracy); acceptable when they all face the line of sight (camlab's own metric),
    # which is not degenerate (off-axis boards are then tilted to the image plane).
    if metrics["tilt_axis_max_deg"] < 12 * TRIGGER_MARGIN:
        required.append("fronto_parallel")
    if metrics["border_coverage"] < (1.0 / 3) * TRIGGER_MARGIN:
        required.append("centre_only")
    if metrics["span_median"] < 0.25 * TRIGGER_MARGIN:
        required.append("far_boards")
    ok = list(required)
    if min(metrics["tilt_max_deg"], metrics["tilt_axis_max_deg"]) < 12 / TRIGGER_MARGIN:
        ok.append("fronto_parallel")
    for feature, code in (("fronto", "fronto_parallel"), ("centre_only", "centre_only"),
                          ("far_boards", "far_boards"), ("views3", "too_few_views"),
                          ("views5", "too_few_views")):
        if feature in spec["name"]:
            ok.append(code)
    if weak:
        ok += DATA_WARNINGS
    if truth[0] not in describing_models_of(model, truth):
        ok.append("high_residuals")  # a model that cannot describe the lens, said so
    # Warnings the truth contradicts: the data is clearly on the good side of camlab's
    # documented trigger (by the same margin), or (high_residuals: "the lens model cannot
    # describe this lens") the fitted model can represent the truth exactly.
    false = {}
    if metrics["views_usable"] >= 8:
        false["too_few_views"] = "%d views" % metrics["views_usable"]
    if min(metrics["tilt_max_deg"], metrics["tilt_axis_max_deg"]) > 12 / TRIGGER_MARGIN:
        false["fronto_parallel"] = "boards tilt up to %.0f deg off the line of sight, %.0f deg off the image plane" % (
            metrics["tilt_max_deg"], metrics["tilt_axis_max_deg"])
    if metrics["border_coverage"] > (1.0 / 3) / TRIGGER_MARGIN:
        false["centre_only"] = "corners reach %.0f%% of the border cells" % (100 * metrics["border_coverage"])
    if metrics["span_median"] > 0.25 / TRIGGER_MARGIN:
        false["far_boards"] = "boards span %.2f of the diagonal" % metrics["span_median"]
    if spec["outliers"] < 0.05 * TRIGGER_MARGIN:
        false["many_outliers"] = "%.0f%% gross outliers" % (100 * spec["outliers"])
    # high_residuals says "the model cannot describe this lens or the corners are poor":
    # false when the fitted model nests the truth and the corners' noise at full weight
    # is at most 0.5 px per coordinate.
    false_if_fitted = {}
    if spec["noise_px"] <= 0.5:
        false_if_fitted["high_residuals"] = describing_models(truth[0])
    return dict(tol=tol, weak=weak, warn_required=sorted(set(required)), warn_ok=sorted(set(ok)),
                warn_false=false, warn_false_if_fitted=false_if_fitted)


def describing_models_of(model, truth):
    """The truth's model when `model` (a case's --model) can represent it exactly, else
    nothing (auto may pick anything; a bare splined model has camlab's own knots)."""
    if model == "truth" or model in describing_models(truth[0]):
        return [truth[0]]
    return []


def describing_models(truth_lensmodel):
    """camlab model names that represent the truth exactly (OpenCV models nest:
    OPENCV4 in 5 in 8 in 12; a splined truth only by its own configuration)."""
    chain = ["LENSMODEL_OPENCV4", "LENSMODEL_OPENCV5", "LENSMODEL_OPENCV8", "LENSMODEL_OPENCV12"]
    if truth_lensmodel in chain:
        return chain[chain.index(truth_lensmodel):]
    return [truth_lensmodel]


def generate(spec, models, out_dir):
    """Writes the dataset of `spec` (OUT/DATASET/: corners.vnl, truth.cameramodel) and one
    case per model (OUT/DATASET__MODEL/case.json). Returns the cases."""
    spec = {**BASE, **spec}
    name = spec["name"]
    d = os.path.join(out_dir, name)
    os.makedirs(d, exist_ok=True)
    W, H = spec["imager"]
    truth = make_truth(spec)
    if not ec.radial_monotonic(truth, W, H):
        raise RuntimeError(name + ": the truth lens folds over inside the imager")
    seed = seed_of(name)
    q, rt_board = synthesize(spec, truth, seed)
    mask = visible_mask(q, spec, truth, rt_board)
    levels, outlier, shift, sigma = corrupt(q, mask, spec, np.random.default_rng(seed + 2))
    qn = add_noise(q, shift, sigma, np.random.default_rng(seed + 3))
    write_vnl(os.path.join(d, "corners.vnl"), qn, mask, levels, spec)
    mrcal.cameramodel(intrinsics=truth, imagersize=(W, H)).write(os.path.join(d, "truth.cameramodel"))
    metrics = data_metrics(spec, q, mask, rt_board)
    fov = ec.field_of_view_deg(truth, W, H)

    # The reference: mrcal's solve of the model camlab is asked for (auto and a bare
    # splined model: the truth's own), started at the truth (OpenCV models nest: extra
    # terms start at zero), on these observations and on MC_TRIALS re-draws of the noise
    # (same poses, levels and outliers): the spread of those solutions against the truth
    # is what the data supports.
    references = {}

    def reference(ref_model, ref_seed):
        if ref_model in references:
            return references[ref_model]
        inputs = reference_solve(ref_model, ref_seed, rt_board, qn, mask, levels, outlier, spec)
        ref = reference_errors(truth, ref_model, inputs, spec)
        trials = []
        for t in range(MC_TRIALS):
            qt = add_noise(q, shift, sigma, np.random.default_rng(seed + 100 + t))
            trials.append(reference_errors(
                truth, ref_model, reference_solve(ref_model, ref_seed, rt_board, qt, mask, levels, outlier, spec),
                spec))
        trials = np.array(trials)
        spread = dict(zip(("err_px", "hfov_deg", "fx_rel"),
                          (float(np.sqrt(np.mean(trials[:, i] ** 2))) for i in range(3))))
        references[ref_model] = dict(
            lensmodel=ref_model, rms_px=float(np.sqrt(np.mean(mrcal.optimizer_callback(**inputs)[1] ** 2))),
            err_px=ref[0], hfov_err_deg=ref[1], fx_rel_err=ref[2], spread=spread, trials=MC_TRIALS,
            uncertainty_points_px=uncertainty_points(inputs, spec, spec["noise_px"]))
        return references[ref_model]

    cases = []
    for model in models:
        ref_model, ref_seed = truth
        if model.startswith("LENSMODEL_OPENCV") and model != truth[0]:
            ref_model = model
            ref_seed = np.zeros(mrcal.lensmodel_num_params(ref_model))
            ref_seed[:len(truth[1])] = truth[1]
        ref = reference(ref_model, ref_seed)
        model_arg = truth[0] if model == "truth" else model
        case_name = name + "__" + model_tag(model)
        case = dict(
            name=case_name,
            dataset=name,
            corners=os.path.join("..", name, "corners.vnl"),
            truth=os.path.join("..", name, "truth.cameramodel"),
            board="%dx%d" % spec["board"],
            spacing_m=spec["spacing"],
            imager="%dx%d" % (W, H),
            model=model_arg,
            generator=dict((k, v) for k, v in spec.items() if k not in ("name", "quick", "models")),
            truth_summary=dict(lensmodel=truth[0], fx_px=float(truth[1][0]), hfov_deg=fov[0],
                               vfov_deg=fov[1], dfov_deg=fov[2]),
            data=dict(metrics, corners_present=int(np.count_nonzero(mask)),
                      corners_total=int(mask.size), outliers=int(np.count_nonzero(outlier)),
                      views_with_missing=int(np.count_nonzero(np.any(~mask, axis=(1, 2))))),
            reference=ref,
            expected=expected_for(spec, model, truth, metrics, ref["spread"]))
        os.makedirs(os.path.join(out_dir, case_name), exist_ok=True)
        with open(os.path.join(out_dir, case_name, "case.json"), "w") as f:
            json.dump(case, f, indent=2, default=float)
        cases.append(case)
    return cases


def generate_cases(out_dir, subset="all", only=(), log=None):
    """Generates every dataset that has a selected case; returns the selected cases."""
    selected = case_list(subset, only)
    out = []
    for spec in CASES:
        models = [m for s, m, _ in selected if s is spec]
        if not models:
            continue
        t0 = time.monotonic()
        cases = generate(spec, models, out_dir)
        out += cases
        if log:
            for c in cases:
                log("%-44s %-16s hfov %6.1f  views %3d  present %5d  ref err %.3f px  4 sigma %.3f px  %.1f s%s%s" % (
                    c["name"], c["truth_summary"]["lensmodel"][10:26], c["truth_summary"]["hfov_deg"],
                    c["data"]["views_usable"], c["data"]["corners_present"], c["reference"]["err_px"],
                    K_SIGMA * c["reference"]["spread"]["err_px"], time.monotonic() - t0,
                    "  weak:" + ",".join(c["expected"]["weak"]) if c["expected"]["weak"] else "",
                    "  requires:" + ",".join(c["expected"]["warn_required"]) if c["expected"]["warn_required"] else ""))
    return out


def main():
    ap = argparse.ArgumentParser(description="Writes the calibration datasets and cases (see the header).")
    ap.add_argument("out_dir")
    ap.add_argument("--subset", choices=["all", "quick"], default="all")
    ap.add_argument("--only", nargs="*", default=[], help="case or dataset names")
    a = ap.parse_args()
    os.makedirs(a.out_dir, exist_ok=True)
    generate_cases(a.out_dir, a.subset, a.only, log=lambda line: print(line, flush=True))


if __name__ == "__main__":
    main()
