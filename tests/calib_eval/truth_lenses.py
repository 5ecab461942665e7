# Truth lenses for the calibration datasets (generate_cases.py), as mrcal
# (lensmodel, intrinsics) pairs: fx, fy, cx, cy (px) then the distortion terms. Each is a
# plausible lens, not a copy of camlab's test lenses; the generator checks that none folds
# over inside its imager. Run with /usr/bin/python3 (Debian's python3-mrcal).

import math

import numpy as np

import evalcore as ec


def truth_opencv4(W, H, hfov):
    dist = [-0.11, 0.045, 3e-4, -2e-4]
    f = ec.focal_for_hfov("LENSMODEL_OPENCV4", dist, W, H, hfov, 0.004 * W, -0.006 * H)
    return "LENSMODEL_OPENCV4", np.array([f, f * 1.0008, (W - 1) / 2 + 0.004 * W, (H - 1) / 2 - 0.006 * H] + dist)


def truth_opencv4_long(W, H, focal_over_diag):
    # A long lens: fx = focal_over_diag x the imager diagonal, little distortion.
    f = focal_over_diag * math.hypot(W, H)
    return "LENSMODEL_OPENCV4", np.array([f, f, (W - 1) / 2 - 0.01 * W, (H - 1) / 2 + 0.008 * H,
                                          -0.35, 0.0, 1e-4, 2e-4])


def truth_opencv5(W, H, hfov):
    dist = [-0.27, 0.085, -1.5e-4, 4e-4, -0.011]
    f = ec.focal_for_hfov("LENSMODEL_OPENCV5", dist, W, H, hfov, -0.005 * W, 0.004 * H)
    return "LENSMODEL_OPENCV5", np.array([f, f * 0.9995, (W - 1) / 2 - 0.005 * W, (H - 1) / 2 + 0.004 * H] + dist)


def truth_opencv8(W, H, hfov):
    # A wide lens between rectilinear and stereographic, r/f = 0.35 tan t + 0.65 * 2 tan(t/2),
    # fitted by OPENCV8's rational radial term out past the imager's corners.
    def g(t):
        return 0.35 * np.tan(t) + 0.65 * 2 * np.tan(t / 2)
    th = np.linspace(1e-4, math.radians(89), 20000)
    f = (W / 2) / np.interp(math.radians(hfov / 2), th, g(th))
    th_corner = np.interp(math.hypot(W, H) / 2 / f, g(th), th)
    k = ec.fit_rational_opencv8(g, min(th_corner * 1.12, math.radians(85)))
    intr = np.array([f, f * 1.001, (W - 1) / 2 + 0.003 * W, (H - 1) / 2 + 0.005 * H,
                     k[0], k[1], 2e-4, -1.5e-4, k[2], k[3], k[4], k[5]])
    return "LENSMODEL_OPENCV8", intr


def truth_splined(W, H, hfov):
    # A fisheye-like lens that no OpenCV model describes exactly: r/f = t + 0.05 t^3 -
    # 0.03 t^5 with a slight anamorphic squeeze and a decentring term, fitted by a
    # SPLINED_STEREOGRAPHIC model whose knot grid differs from camlab's default.
    lensmodel = "LENSMODEL_SPLINED_STEREOGRAPHIC_order=3_Nx=12_Ny=9_fov_x_deg=%d" % int(round(hfov * 1.25))
    def rho(t):
        return t + 0.05 * t ** 3 - 0.03 * t ** 5
    f = (W / 2) / rho(math.radians(hfov / 2))
    cx, cy = (W - 1) / 2 + 0.004 * W, (H - 1) / 2 - 0.003 * H
    def target(v):
        t = np.arccos(np.clip(v[:, 2], -1, 1))
        az = np.arctan2(v[:, 1], v[:, 0])
        r = f * rho(t)
        x = r * np.cos(az)
        y = r * np.sin(az) * 1.006
        x += f * 0.004 * t * t
        y += f * 0.002 * t * t
        return np.stack((cx + x, cy + y), axis=-1)
    intr, _ = ec.fit_splined(lensmodel, W, H, f, cx, cy, target)
    return lensmodel, intr


def make_truth(spec):
    W, H = spec["imager"]
    kind = spec["lens"]
    if kind == "opencv4":
        return truth_opencv4(W, H, spec["hfov"])
    if kind == "opencv4_long":
        return truth_opencv4_long(W, H, spec["focal_over_diag"])
    if kind == "opencv5":
        return truth_opencv5(W, H, spec["hfov"])
    if kind == "opencv8":
        return truth_opencv8(W, H, spec["hfov"])
    if kind == "splined":
        return truth_splined(W, H, spec["hfov"])
    raise ValueError(kind)
