#!/usr/bin/python3
# mrcal's own projection uncertainty on a problem camlab solved (tests/unit/calib,
# uncertainty_test.cpp): reads camlab's export of mrcal's optimization_inputs
# (calib/uncertainty.h, mrcal_optimization_inputs) and query points, and writes the
# worst-direction stdev that mrcal.projection_uncertainty (mrcal 2.2) gives for each.
#
#   /usr/bin/python3 mrcal_uncertainty.py IN.json OUT.json
#
# IN.json: {"optimization_inputs": {...}, "sigma_px": s,
#           "queries": [{"x": px, "y": px, "distance_m": d or null (infinity)}, ...]}
# OUT.json: {"worst_px": [...], "rms_px": [...]}
import json
import sys

import numpy as np
import mrcal


def main():
    with open(sys.argv[1]) as f:
        spec = json.load(f)
    oi = spec["optimization_inputs"]
    inputs = dict(
        lensmodel=oi["lensmodel"],
        intrinsics=np.array(oi["intrinsics"], dtype=float),
        extrinsics_rt_fromref=np.zeros((0, 6), dtype=float),
        frames_rt_toref=np.array(oi["frames_rt_toref"], dtype=float),
        points=None,
        observations_board=np.array(oi["observations_board"], dtype=float),
        indices_frame_camintrinsics_camextrinsics=np.array(
            oi["indices_frame_camintrinsics_camextrinsics"], dtype=np.int32),
        observations_point=None,
        indices_point_camintrinsics_camextrinsics=None,
        imagersizes=np.array(oi["imagersizes"], dtype=np.int32),
        calobject_warp=np.array(oi["calobject_warp"], dtype=float),
        calibration_object_spacing=oi["calibration_object_spacing"],
        do_optimize_intrinsics_core=oi["do_optimize_intrinsics_core"],
        do_optimize_intrinsics_distortions=oi["do_optimize_intrinsics_distortions"],
        do_optimize_extrinsics=True,
        do_optimize_frames=True,
        do_optimize_calobject_warp=oi["do_optimize_calobject_warp"],
        do_apply_regularization=oi["do_apply_regularization"],
        do_apply_outlier_rejection=False,
    )
    model = mrcal.cameramodel(optimization_inputs=inputs, icam_intrinsics=0)
    lensmodel, intrinsics = model.intrinsics()
    worst, rms = [], []
    for q in spec["queries"]:
        v = mrcal.unproject(np.array((q["x"], q["y"]), dtype=float), lensmodel, intrinsics,
                            normalize=True)
        atinf = q["distance_m"] is None
        p = v if atinf else v * q["distance_m"]
        kw = dict(atinfinity=atinf, observed_pixel_uncertainty=spec["sigma_px"])
        worst.append(float(mrcal.projection_uncertainty(p, model, what="worstdirection-stdev", **kw)))
        rms.append(float(mrcal.projection_uncertainty(p, model, what="rms-stdev", **kw)))
    with open(sys.argv[2], "w") as f:
        json.dump({"worst_px": worst, "rms_px": rms}, f)


if __name__ == "__main__":
    main()
