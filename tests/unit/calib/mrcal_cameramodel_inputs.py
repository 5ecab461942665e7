#!/usr/bin/python3
# mrcal's own view of a .cameramodel camlab wrote with optimization_inputs
# (calib/model_io.h, cameramodel_text_with_inputs; tests/unit/calib,
# cameramodel_optimization_inputs_test.cpp): loads it with mrcal.cameramodel (mrcal 2.2),
# evaluates the stored problem with mrcal's optimizer, and computes mrcal's projection
# uncertainty, for the C++ test to compare with camlab's numbers.
#
#   /usr/bin/python3 mrcal_cameramodel_inputs.py IN.json OUT.json
#
# IN.json:  {"model": path, "sigma_px": s, "downweighted_views": [i, ...],
#            "queries": [{"x": px, "y": px, "distance_m": d or null (infinity)}, ...]}
# OUT.json: {"types": {key: "str" | "bool" | "float" | "NoneType" | "<dtype> <shape>"},
#            "icam_intrinsics": i, "intrinsics_equal": bool,
#            "rms_px": inlier RMS of the unweighted residuals (camlab's definition),
#            "inliers": n, "board_measurements": n,
#            "reoptimized_max_dintrinsics_rel": largest relative change of an intrinsic
#                when mrcal.optimize(**inputs) restarts from the stored optimum,
#            "reoptimized_rms_px": mrcal.optimize's RMS after that,
#            "worst_px": [...] (mrcal.projection_uncertainty, worst direction)}
import copy
import json
import sys

import numpy as np
import mrcal


def describe(v):
    if isinstance(v, np.ndarray):
        return f"{v.dtype} {tuple(v.shape)}"
    return type(v).__name__


def main():
    with open(sys.argv[1]) as f:
        spec = json.load(f)
    model = mrcal.cameramodel(spec["model"])
    inputs = model.optimization_inputs()
    out = {"types": {k: describe(v) for k, v in inputs.items()},
           "icam_intrinsics": int(model.icam_intrinsics())}
    lensmodel, intrinsics = model.intrinsics()
    out["intrinsics_equal"] = bool(lensmodel == inputs["lensmodel"] and
                                   np.array_equal(intrinsics, inputs["intrinsics"][0]))

    # The measurements of the stored problem at the stored state, as mrcal's tools get
    # them (mrcal-show-residuals: optimizer_callback(**inputs)[1]); the board's come first,
    # weighted: x = w (q - q_obs) per corner.
    x = mrcal.optimizer_callback(**inputs)[1]
    obs = inputs["observations_board"]
    w = obs[..., 2].ravel()
    nboard = w.size * 2
    xy = x[:nboard].reshape(-1, 2)
    down = np.zeros(obs.shape[0], dtype=bool)
    down[spec["downweighted_views"]] = True
    inlier = (w > 0) & ~np.repeat(down, obs.shape[1] * obs.shape[2])
    e2 = np.sum((xy[inlier] / w[inlier, None]) ** 2, axis=-1)
    out["rms_px"] = float(np.sqrt(np.mean(e2)))
    out["inliers"] = int(np.count_nonzero(inlier))
    out["board_measurements"] = int(nboard)

    # Restarting mrcal's optimizer from the stored state: at the optimum of exactly this
    # problem nothing moves.
    again = copy.deepcopy(inputs)
    stats = mrcal.optimize(**again)
    i0 = inputs["intrinsics"][0]
    out["reoptimized_max_dintrinsics_rel"] = float(
        np.max(np.abs(again["intrinsics"][0] - i0) / np.maximum(np.abs(i0), 1e-3)))
    out["reoptimized_rms_px"] = float(stats["rms_reproj_error__pixels"])

    worst = []
    for q in spec["queries"]:
        v = mrcal.unproject(np.array((q["x"], q["y"]), dtype=float), lensmodel, intrinsics,
                            normalize=True)
        atinf = q["distance_m"] is None
        p = v if atinf else v * q["distance_m"]
        worst.append(float(mrcal.projection_uncertainty(
            p, model, atinfinity=atinf, what="worstdirection-stdev",
            observed_pixel_uncertainty=spec["sigma_px"])))
    out["worst_px"] = worst
    with open(sys.argv[2], "w") as f:
        json.dump(out, f)


if __name__ == "__main__":
    main()
