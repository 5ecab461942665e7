# Shared by generate_cases.py and run_cases.py: truth lenses, the error of a fitted model
# against the truth, and field of view, all computed with mrcal's own Python (2.2), never
# with camlab's code, so the check is independent of what it checks.
#
# Conventions (mrcal's and camlab's): pixel centres at integer coordinates; the imager
# spans -0.5 .. W-0.5; intrinsics are fx, fy, cx, cy (px) then the distortion terms.
# Run with /usr/bin/python3 (Debian's python3-mrcal).

import math

import numpy as np
import mrcal


def central_grid(W, H, fraction=0.8, n=40):
    """Pixels (n*n, 2) over the central `fraction` of the imager (camlab's definition in
    calib/lens_model.h projection_difference: cell centres of an n x n grid)."""
    u = (np.arange(n) + 0.5) / n
    x = (0.5 + (u - 0.5) * fraction) * W - 0.5
    y = (0.5 + (u - 0.5) * fraction) * H - 0.5
    xx, yy = np.meshgrid(x, y)
    return np.ascontiguousarray(np.stack((xx.ravel(), yy.ravel()), axis=-1))


def unit(v):
    return v / np.linalg.norm(v, axis=-1)[..., None]


def projection_error_px(truth, fit, W, H, fraction=0.8, n=40, at=None):
    """RMS and max (px) of the projection difference between two (lensmodel, intrinsics)
    over the central `fraction` of the imager: each grid pixel is unprojected through
    the truth, turned by the rotation that best aligns the two camera frames (fitted by
    Gauss-Newton on the pixel error, as mrcal's projection_diff fits an implied
    rotation: it trades with the principal point and is not an error of the lens), and
    projected through the fit. Returns (rms, max, rotation_deg); (inf, inf, nan) when a
    model cannot unproject or project the grid. With `at` (pixels (N, 2)), a fourth value:
    the error at each of those pixels, through the same rotation (inf where a model
    cannot map it)."""
    q = central_grid(W, H, fraction, n)
    try:
        v = unit(mrcal.unproject(q, *truth))
    except Exception:
        return math.inf, math.inf, math.nan
    if not np.all(np.isfinite(v)):
        return math.inf, math.inf, math.nan
    r = np.zeros(3)
    for _ in range(10):
        vr, dvr_dr, _ = mrcal.rotate_point_r(r, v, get_gradients=True)
        qf, dq_dv, _ = mrcal.project(vr, *fit, get_gradients=True)
        if not np.all(np.isfinite(qf)):
            return math.inf, math.inf, math.nan
        e = (qf - q).ravel()
        J = np.einsum('nij,njk->nik', dq_dv, dvr_dr).reshape(-1, 3)
        d = np.linalg.lstsq(J, -e, rcond=None)[0]
        r = r + d
        if np.max(np.abs(d)) < 1e-12:
            break
    qf = mrcal.project(mrcal.rotate_point_r(r, v), *fit)
    d = np.linalg.norm(qf - q, axis=-1)
    if not np.all(np.isfinite(d)):
        return math.inf, math.inf, math.nan
    out = (float(np.sqrt(np.mean(d * d))), float(np.max(d)), float(np.linalg.norm(r) * 180 / math.pi))
    if at is None:
        return out
    try:
        qa = np.ascontiguousarray(at, dtype=float)
        fa = mrcal.project(mrcal.rotate_point_r(r, unit(mrcal.unproject(qa, *truth))), *fit)
        da = np.linalg.norm(fa - qa, axis=-1)
        da[~np.isfinite(da)] = math.inf
    except Exception:
        da = np.full(len(at), math.inf)
    return out + ([float(x) for x in da],)


def angle_deg(a, b):
    return math.degrees(math.atan2(np.linalg.norm(np.cross(a, b)), float(np.dot(a, b))))


def field_of_view_deg(model, W, H):
    """(horizontal, vertical, diagonal) FOV in degrees by unprojecting the image edges
    (pixel edges -0.5 and W-0.5, through the centre row and column; the diagonal is the
    mean of the two corner-to-corner angles), as docs/calibration.md defines it. None
    when the model does not invert at the edges (the unprojected directions do not
    project back to the edge pixels within 0.01 px)."""
    xm, ym = (W - 1) / 2, (H - 1) / 2
    q = np.array([[-0.5, ym], [W - 0.5, ym], [xm, -0.5], [xm, H - 0.5],
                  [-0.5, -0.5], [W - 0.5, H - 0.5], [W - 0.5, -0.5], [-0.5, H - 0.5]])
    try:
        v = mrcal.unproject(q, *model)
        back = mrcal.project(v, *model)
    except Exception:
        return None
    if not (np.all(np.isfinite(v)) and np.all(np.isfinite(back))) or np.max(np.abs(back - q)) > 0.01:
        return None
    return (angle_deg(v[0], v[1]), angle_deg(v[2], v[3]),
            0.5 * (angle_deg(v[4], v[5]) + angle_deg(v[6], v[7])))


def field_of_view_parts_deg(model, W, H):
    """(horizontal, vertical, diagonal) FOV in degrees, each on its own: None for one whose
    edge points do not unproject and project back within 0.01 px (a model that folds over
    only in the image corners keeps its horizontal and vertical FOV), as camlab's report
    gives them."""
    xm, ym = (W - 1) / 2, (H - 1) / 2
    q = np.array([[-0.5, ym], [W - 0.5, ym], [xm, -0.5], [xm, H - 0.5],
                  [-0.5, -0.5], [W - 0.5, H - 0.5], [W - 0.5, -0.5], [-0.5, H - 0.5]])
    ok = []
    v = []
    for p in q:
        try:
            d = mrcal.unproject(p, *model)
            back = mrcal.project(d, *model)
            good = bool(np.all(np.isfinite(d)) and np.all(np.isfinite(back)) and
                        np.max(np.abs(back - p)) <= 0.01)
        except Exception:
            d, good = None, False
        ok.append(good)
        v.append(d)
    h = angle_deg(v[0], v[1]) if ok[0] and ok[1] else None
    vert = angle_deg(v[2], v[3]) if ok[2] and ok[3] else None
    diag = (0.5 * (angle_deg(v[4], v[5]) + angle_deg(v[6], v[7]))
            if all(ok[4:8]) else None)
    return (h, vert, diag)


# ---- Truth lenses -------------------------------------------------------------------

def radial_monotonic(model, W, H, margin=1.15):
    """True when the model's projection moves outwards monotonically along rays out to
    `margin` x the imager's corner angle (a polynomial model that folds over inside the
    imager would image no real lens)."""
    corners = np.array([[-0.5, -0.5], [W - 0.5, -0.5], [-0.5, H - 0.5], [W - 0.5, H - 0.5]])
    v = unit(mrcal.unproject(corners, *model))
    for d in v:
        th_max = min(math.acos(max(-1.0, min(1.0, d[2]))) * margin, math.radians(89))
        az = math.atan2(d[1], d[0])
        th = np.linspace(1e-4, th_max, 400)
        p = np.stack((np.sin(th) * math.cos(az), np.sin(th) * math.sin(az), np.cos(th)), axis=-1)
        q = mrcal.project(p, *model)
        c = np.array(model[1][2:4])
        r = np.linalg.norm(q - c, axis=-1)
        if not np.all(np.isfinite(r)) or np.any(np.diff(r) <= 0):
            return False
    return True


def focal_for_hfov(lensmodel, distortion, W, H, hfov_deg, cx_off=0.0, cy_off=0.0):
    """fx = fy (px) that gives the lens a horizontal FOV of hfov_deg (bisection on the
    FOV computed by unprojecting the edges through the distorted model)."""
    lo, hi = W / 200.0, W * 200.0
    for _ in range(100):
        f = math.sqrt(lo * hi)
        intr = np.array([f, f, (W - 1) / 2 + cx_off, (H - 1) / 2 + cy_off] + list(distortion))
        fov = field_of_view_deg((lensmodel, intr), W, H)
        if fov is None or fov[0] > hfov_deg:
            lo = f
        else:
            hi = f
    return math.sqrt(lo * hi)


def fit_rational_opencv8(mapping, theta_max_rad):
    """k1..k6 of OPENCV8's radial term r_d = r (1 + k1 r^2 + k2 r^4 + k3 r^6) /
    (1 + k4 r^2 + k5 r^4 + k6 r^6), r = tan(theta), that reproduces r_d = mapping(theta)
    (normalised by the focal length) over 0 .. theta_max: linear least squares on the
    cross-multiplied form."""
    th = np.linspace(1e-3, theta_max_rad, 300)
    r = np.tan(th)
    y = mapping(th) / r  # wanted ratio
    r2 = r * r
    A = np.stack((r2, r2 ** 2, r2 ** 3, -y * r2, -y * r2 ** 2, -y * r2 ** 3), axis=-1)
    k = np.linalg.lstsq(A, y - 1, rcond=None)[0]
    return k


def fit_splined(lensmodel, W, H, fx, cx, cy, target_q_of_v, margin=1.1, ridge=1e-6):
    """Control points of a SPLINED_STEREOGRAPHIC model (core fx = fy, cx, cy) that
    reproduce target_q_of_v (unit directions (N,3) -> pixels (N,2)) over the directions
    that land on the imager (with `margin`). The projection is linear in the control
    points, so this is a linear least-squares fit (with a small ridge that keeps knots
    outside the field tame)."""
    n = mrcal.lensmodel_num_params(lensmodel)
    intr0 = np.zeros(n)
    intr0[:4] = (fx, fx, cx, cy)
    # Directions over the field: a dense grid in stereographic coordinates.
    ux, uy = mrcal.knots_for_splined_models(lensmodel)
    gx = np.linspace(ux[0], ux[-1], 120)
    gy = np.linspace(uy[0], uy[-1], 90)
    u = np.stack(np.meshgrid(gx, gy), axis=-1).reshape(-1, 2)
    v = unit(mrcal.unproject_stereographic(np.ascontiguousarray(u)))
    qt = target_q_of_v(v)
    mx, my = (margin - 1) * W / 2, (margin - 1) * H / 2
    keep = (qt[:, 0] > -mx) & (qt[:, 0] < W + mx) & (qt[:, 1] > -my) & (qt[:, 1] < H + my) & (v[:, 2] > 0.05)
    v, qt = v[keep], qt[keep]
    q0, _, dq_di = mrcal.project(v, lensmodel, intr0, get_gradients=True)
    A = dq_di[:, :, 4:].reshape(-1, n - 4)
    b = (qt - q0).ravel()
    A = np.vstack((A, math.sqrt(ridge) * fx * np.eye(n - 4)))
    b = np.concatenate((b, np.zeros(n - 4)))
    ctrl = np.linalg.lstsq(A, b, rcond=None)[0]
    intr = intr0.copy()
    intr[4:] = ctrl
    fit_err = np.linalg.norm(mrcal.project(v, lensmodel, intr) - qt, axis=-1)
    return intr, float(np.max(fit_err))
