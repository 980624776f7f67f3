#!/usr/bin/env python3
"""Independent reference for camera-trajectory interpolation (TUM knots -> c2w pose).

Written from the primary sources listed below (read at the pinned commits) and
from textbooks, without looking at refrender's C code.  numpy + scipy only.
Run ``/usr/bin/python3 tests/trajectory_reference.py`` for the self-tests.

CONVENTIONS (what BAD-Gaussians' TUM export writes; for checking a TUM reader)
------------------------------------------------------------------------------
Sources: WU-CVGL/BAD-Gaussians
  scripts/tools/export_poses_from_ckpt.py @ 24c8f45b445a940cf49ece5ce17ac08d18bd7d1a
  bad_gaussians/bad_utils.py              @ fb0e385e3002199ba76ff82f9a5f6d8b4ce8a8fc
  bad_gaussians/deblur_nerf_dataparser.py @ 5f664ef26e527a9e6bca47ef14bd0ee461bbde7c
  bad_gaussians/bad_camera_optimizer.py   @ f9784ca4c3dee046a61d79dbc187272e08248f16
  nerfstudio-project/nerfstudio nerfstudio/data/dataparsers/colmap_dataparser.py
                                          @ 9862bc38477c5f2c610a0830e01df4866e61122f
* Line format ``t tx ty tz qx qy qz qw`` (quaternion scalar LAST): bad_utils.py:64
  writes the 7 numbers of a pypose SE3 tensor in storage order (t, then q xyzw).
  The quaternion sign is not canonicalised (qw may be negative).  Values are
  float32 printed with Python float repr, so |q| = 1 only to ~1e-7.
* The pose is CAMERA-TO-WORLD: export_poses_from_ckpt.py:51 converts the
  dataparser's ``camera_to_worlds`` (c2w) and :67 writes ``c2w @ delta``; the
  translation is therefore the camera centre in world coordinates.
* Camera axes are nerfstudio's OpenGL axes: x right, y up, z backwards (the
  camera looks along -z).  The COLMAP (OpenCV) c2w gets ``c2w[0:3,1:3] *= -1``
  in ColmapDataParser._get_all_images_and_cameras (nerfstudio, commit above).
* The world is nerfstudio's re-oriented, re-centred, rescaled world, not
  COLMAP's: world axes permuted (y<->z, sign flip), then
  auto_orient_and_center_poses (orientation "up", centre "poses"), then the
  translations are divided by max|t| and multiplied by scale_factor, whose
  default is 0.25 in DeblurNerfDataParserConfig (deblur_nerf_dataparser.py:67).
* The exported pose is the MID-exposure pose: export_poses_from_ckpt.py:55-63
  evaluates linear_interpolation_mid (2 knots) or the 4-knot cubic at u = 0.5;
  Bezier checkpoints are not supported by the exporter (assert_never, :62-63).
* Timestamps are 0.0, 1.0, ..., N-1 (export_poses_from_ckpt.py:69): the index in
  the *train* split (:45 split="train"; eval_mode "interval" leaves out every
  8th image unless a ``hold=N`` file says otherwise, deblur_nerf_dataparser.py:
  146-154), not a time in seconds.
* The reader TrajectoryIO.load_tum_trajectory (bad_utils.py:18-38) drops only a
  first line starting with '#'.  ``parse_tum`` below skips every '#'/blank line.

RULES AND THEIR SOURCES
-----------------------
Poses are c2w (p, R): p (3,) camera centre, R (3,3).  Knots are (t, p, q) with q
unit (x, y, z, w).  Hamilton products; q1*q2 <-> R1 @ R2.  "Log" below is the
principal logarithm (rotation angle in [0, pi]); Exp/Log of SE(3) use the
textbook closed forms of Lynch & Park, "Modern Robotics" (2017), Sec. 3.2.3
(Rodrigues, so(3) log) and Sec. 3.3.3 (Prop. 3.25: exp of a twist with
G(theta) = V; matrix log of a rigid-body motion with G^-1).  Twist order is
xi = (rho, omega), T = [[Exp(omega), V(omega) rho], [0, 1]].

pose_linear -- WU-CVGL/BAD-Gaussians @ f9784ca4c3dee046a61d79dbc187272e08248f16
  bad_gaussians/spline_functor.py:43-80 (translation lerp :72; q_start.Inv() @
  q_end, .Log(), Exp(u*r), q_start @ ... :74-77); segment/u from time:
  bad_gaussians/spline.py:86-117 @ fb0e385e3002199ba76ff82f9a5f6d8b4ce8a8fc.
  Log is pypose SO3_Log (pypose/pypose v0.6.8 = 931dc6f496936792059806eee190b9d6755c8c6f,
  pypose/lietensor/operation.py:304-324): 2 atan(|v|/w) v/|v|, which for w < 0
  returns the log of -q, i.e. the SHORT arc (angle <= pi).  scipy's Slerp also
  takes the short arc, so it is used.  Same rule in WU-CVGL/BAD-NeRF
  Spline.py:246-273 @ 80a590df52e9c434e1e603a028a7d8bb42da053c (log_q2r :156-157
  is the same atan form; BAD-NeRF clamps u to [1e-6, 1-1e-6], :250-253).
pose_se3 -- textbook screw motion (no deblurring source uses it per segment;
  "linear" in the sources is split R^3 x SO(3), not screw: src/TRAJECTORIES.md's table).
pose_cubic -- BAD-Gaussians @ f9784ca.. spline_functor.py:83-142: translation
  weights :113-118, applied :121; rotation weights :124-128 (cumulative),
  relative rotations q_{i}^-1 q_{i+1} and so(3) Log :131-132, Exp :133,
  q0 prepended :134-138, pp.cumprod(..., left=False) :139 = RIGHT product
  y = x0 x1 x2 x3 (pypose v0.6.8 pypose/basics/ops.py:153-204, right branch :204;
  the scan at :27-36).  Segment choice: spline.py:105-110 (start_index - 1 for
  degree 3), domain [t_1, t_{n-2}]: spline.py:129-147.  BAD-NeRF Spline.py:276-336
  writes the same thing explicitly: q0 (x) (Exp(B1 r01) (x) (Exp(B2 r12) (x)
  Exp(B3 r23))) at :313-327.
pose_bezier_quat_cartesian (alias pose_bezier) -- taekkii/deblurgs (DeblurGS)
  @ e0587475f8e9d50b98329dbc2e18ab07f7c22d70, curve_type "quarternion_cartesian":
  scene/motion.py:191-194 (control points = c2w quaternion and camera centre),
  :242-246 (Bernstein sum of raw quaternion components, then q/|q|; translation
  Bernstein sum); scene/bezier.py:48,62,81 (weights, sum).  No hemisphere
  alignment of the quaternions in the source, none here.
pose_bezier_se3_sum (alias pose_bezier_se3) -- DeblurGS @ e0587475.., curve_type
  "se3" (the default, arguments/__init__.py:60-62: curve_order 9 = degree 9,
  21 subframes): scene/motion.py:196-205 se3_log_map of the absolute c2w
  (OpenCV axes; pytorch3d row-vector layout, transposed back), :248-252
  Exp(sum b_k xi_k).  utils/pytorch3d_functions.py:462-541 (log: rotation log,
  rho = V^-1 p, :533-539), :373-457 (exp: t = V rho, :440-447), V :546-573.
  xi is the full se(3) log (with V), NOT (p, omega).
pose_bezier_se3_product -- BAD-Gaussians @ f9784ca.. spline_functor.py:144-183:
  Bernstein weights :163,174-177; Exp(b_i * Log T_i) with pypose SE3_Log
  (full se(3), rho = Jl^-1 p = V^-1 p; operation.py:373-382, Exp :398-405) at
  :180; right cumulative product :181.  In BAD-Gaussians the knots are
  per-image corrections applied on the right of the dataparser c2w
  (bad_camera_optimizer.py:131,230,235; ``bezier_degree=9`` means 9 knots,
  degree 8, :49,95-96); pass ``reference`` to reproduce that.
DeblurGS's Bernstein indexing is reversed (scene/bezier.py:62: control point k
has weight C(C,k) t^(C-k) (1-t)^k, so ITS control point 0 is the curve's END);
here knot i (in time order) has weight C(n-1,i) (1-u)^(n-1-i) u^i: the same curve
with the control points listed in time order.
BAD-NeRF (Spline.py:199-243) stores se(3) knots as (omega, u), rotation first.

Domain: times outside a curve's domain raise ValueError.  The sources' own
Spline.get_segment would index past the last knot at the closed upper bound
(spline.py:107-115); here the upper bound is included (u = 1 of the last segment).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.interpolate import BPoly, BSpline
from scipy.linalg import expm, logm
from scipy.spatial.transform import Rotation, Slerp
from scipy.special import comb

__all__ = [
    "pose_linear", "pose_se3", "pose_cubic", "pose_bezier", "pose_bezier_se3",
    "pose_bezier_quat_cartesian", "pose_bezier_se3_sum", "pose_bezier_se3_product",
    "so3_exp", "so3_log", "se3_exp", "se3_log", "parse_tum", "bernstein",
    "cubic_weights", "cubic_cumulative_weights",
]

# ----------------------------------------------------------------------------
# Lie group closed forms (Lynch & Park, Modern Robotics, Sec. 3.2.3 and 3.3.3)
# ----------------------------------------------------------------------------


def hat(w):
    w = np.asarray(w, dtype=np.float64)
    return np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])


def vee(W):
    return np.array([W[2, 1], W[0, 2], W[1, 0]], dtype=np.float64)


def _coeffs(theta):
    """A = sin t / t, B = (1 - cos t)/t^2, C = (t - sin t)/t^3 (Taylor near 0)."""
    if theta < 1e-4:
        t2 = theta * theta
        return (1.0 - t2 / 6.0 + t2 * t2 / 120.0,
                0.5 - t2 / 24.0 + t2 * t2 / 720.0,
                1.0 / 6.0 - t2 / 120.0 + t2 * t2 / 5040.0)
    s, c = math.sin(theta), math.cos(theta)
    return s / theta, (1.0 - c) / theta ** 2, (theta - s) / theta ** 3


def so3_exp(w):
    """Rodrigues: R = I + A W + B W^2."""
    w = np.asarray(w, dtype=np.float64)
    W = hat(w)
    A, B, _ = _coeffs(float(np.linalg.norm(w)))
    return np.eye(3) + A * W + B * (W @ W)


def so3_log(R):
    """Principal log, angle in [0, pi].  theta = atan2(|s|, c) with
    s = vee(R - R^T)/2 = sin(theta) a, c = (tr R - 1)/2; near pi the axis comes
    from (R + R^T)/2 - c I = (1 - c) a a^T."""
    R = np.asarray(R, dtype=np.float64)
    s = 0.5 * vee(R - R.T)
    sn = float(np.linalg.norm(s))
    c = 0.5 * (np.trace(R) - 1.0)
    theta = math.atan2(sn, c)
    if theta < 1e-4:
        t2 = theta * theta
        return s * (1.0 + t2 / 6.0 + 7.0 * t2 * t2 / 360.0)  # theta / sin(theta)
    if math.pi - theta > 1e-3:
        return s * (theta / sn)
    S = 0.5 * (R + R.T) - c * np.eye(3)            # (1 - c) a a^T
    i = int(np.argmax(np.diag(S)))
    a = S[:, i] / math.sqrt(S[i, i])
    a /= np.linalg.norm(a)
    if np.dot(a, s) < 0.0:
        a = -a
    return theta * a


def so3_V(w):
    """V = G(theta)/theta = I + B W + C W^2 (left Jacobian of SO(3))."""
    W = hat(w)
    _, B, C = _coeffs(float(np.linalg.norm(w)))
    return np.eye(3) + B * W + C * (W @ W)


def so3_V_inv(w):
    """V^-1 = I - W/2 + (1/t^2)(1 - t sin t / (2 (1 - cos t))) W^2."""
    W = hat(w)
    t = float(np.linalg.norm(w))
    if t < 1e-4:
        t2 = t * t
        k = 1.0 / 12.0 + t2 / 720.0 + t2 * t2 / 30240.0
    else:
        k = (1.0 - t * math.sin(t) / (2.0 * (1.0 - math.cos(t)))) / (t * t)
    return np.eye(3) - 0.5 * W + k * (W @ W)


def se3_exp(xi):
    """xi = (rho, omega) -> 4x4 T = [[Exp(omega), V(omega) rho], [0, 1]]."""
    xi = np.asarray(xi, dtype=np.float64)
    T = np.eye(4)
    T[:3, :3] = so3_exp(xi[3:])
    T[:3, 3] = so3_V(xi[3:]) @ xi[:3]
    return T


def se3_log(T):
    """4x4 T -> xi = (rho, omega), omega = Log R, rho = V(omega)^-1 p."""
    T = np.asarray(T, dtype=np.float64)
    w = so3_log(T[:3, :3])
    return np.concatenate([so3_V_inv(w) @ T[:3, 3], w])


def se3_hat(xi):
    M = np.zeros((4, 4))
    M[:3, :3] = hat(xi[3:])
    M[:3, 3] = xi[:3]
    return M


def to_matrix(p, R):
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = p
    return T


def from_matrix(T):
    return np.array(T[:3, 3], dtype=np.float64), np.array(T[:3, :3], dtype=np.float64)


def quat_to_R(q):
    return Rotation.from_quat(np.asarray(q, dtype=np.float64)).as_matrix()  # (x,y,z,w)


# ----------------------------------------------------------------------------
# knots, TUM
# ----------------------------------------------------------------------------


def _knots(knots, min_count=2, uniform=False):
    if len(knots) < min_count:
        raise ValueError(f"need at least {min_count} knots, got {len(knots)}")
    ts = np.array([float(k[0]) for k in knots])
    P = np.array([np.asarray(k[1], dtype=np.float64).reshape(3) for k in knots])
    Q = np.array([np.asarray(k[2], dtype=np.float64).reshape(4) for k in knots])
    if not (np.all(np.isfinite(ts)) and np.all(np.isfinite(P)) and np.all(np.isfinite(Q))):
        raise ValueError("non-finite knot")
    if np.any(np.diff(ts) <= 0.0):
        raise ValueError("knot times must increase strictly")
    n = np.linalg.norm(Q, axis=1)
    if np.any(np.abs(n - 1.0) > 1e-3):
        raise ValueError("knot quaternions must be unit (x, y, z, w)")
    Q = Q / n[:, None]
    if uniform:
        d = np.diff(ts)
        tol = 1e-6 * d[0] + 8.0 * np.finfo(np.float64).eps * max(abs(ts[0]), abs(ts[-1]))
        if np.any(np.abs(d - d[0]) > tol):
            raise ValueError("cubic B-spline knots must be uniformly spaced in time")
    return ts, P, Q


def _check_time(t, lo, hi):
    t = float(t)
    if not np.isfinite(t) or t < lo or t > hi:
        raise ValueError(f"time {t!r} outside the curve's domain [{lo!r}, {hi!r}]")
    return t


def _segment(ts, t):
    """k with ts[k] <= t <= ts[k+1]; the last segment includes its upper end."""
    k = int(np.searchsorted(ts, t, side="right")) - 1
    return min(max(k, 0), len(ts) - 2)


def parse_tum(text):
    """TUM text -> knots [(t, p, q_xyzw)], skipping '#' and blank lines."""
    knots = []
    for line in text.splitlines():
        s = line.strip()
        if not s or s.startswith("#"):
            continue
        v = [float(x) for x in s.split()]
        if len(v) != 8:
            raise ValueError(f"TUM line needs 8 numbers: {line!r}")
        knots.append((v[0], np.array(v[1:4]), np.array(v[4:8])))
    return knots


# ----------------------------------------------------------------------------
# interpolations
# ----------------------------------------------------------------------------


def pose_linear(knots, t):
    """p = (1-u) p_k + u p_{k+1};  R = R_k Exp(u Log(R_k^T R_{k+1})) (short arc)."""
    ts, P, Q = _knots(knots, 2)
    t = _check_time(t, ts[0], ts[-1])
    k = _segment(ts, t)
    u = (t - ts[k]) / (ts[k + 1] - ts[k])
    p = (1.0 - u) * P[k] + u * P[k + 1]
    R = Slerp([0.0, 1.0], Rotation.from_quat(Q[k:k + 2]))([u]).as_matrix()[0]
    return p, R


def pose_se3(knots, t):
    """T = T_k Exp(u Log(T_k^-1 T_{k+1})): constant-twist screw motion."""
    ts, P, Q = _knots(knots, 2)
    t = _check_time(t, ts[0], ts[-1])
    k = _segment(ts, t)
    u = (t - ts[k]) / (ts[k + 1] - ts[k])
    Tk = to_matrix(P[k], quat_to_R(Q[k]))
    Tk1 = to_matrix(P[k + 1], quat_to_R(Q[k + 1]))
    return from_matrix(Tk @ se3_exp(u * se3_log(np.linalg.inv(Tk) @ Tk1)))


def cubic_weights(u):
    """Uniform cubic B-spline weights of control points k-1, k, k+1, k+2."""
    return np.array([(1.0 - u) ** 3 / 6.0,
                     (3.0 * u ** 3 - 6.0 * u ** 2 + 4.0) / 6.0,
                     (-3.0 * u ** 3 + 3.0 * u ** 2 + 3.0 * u + 1.0) / 6.0,
                     u ** 3 / 6.0])


def cubic_cumulative_weights(u):
    """B~_j = sum_{i>=j} B_i, j = 1..3: [5+3u-3u^2+u^3, 1+3u+3u^2-2u^3, u^3]/6."""
    return np.array([(5.0 + 3.0 * u - 3.0 * u ** 2 + u ** 3) / 6.0,
                     (1.0 + 3.0 * u + 3.0 * u ** 2 - 2.0 * u ** 3) / 6.0,
                     u ** 3 / 6.0])


def pose_cubic(knots, t):
    """Uniform cubic B-spline (BAD-Gaussians / BAD-NeRF form) on [t_1, t_{n-2}].
    p = sum_j B_j(u) p_{k-1+j};
    R = R_{k-1} Exp(B~1 Log(R_{k-1}^T R_k)) Exp(B~2 Log(R_k^T R_{k+1}))
                Exp(B~3 Log(R_{k+1}^T R_{k+2}))   (products on the right)."""
    ts, P, Q = _knots(knots, 4, uniform=True)
    n = len(ts)
    t = _check_time(t, ts[1], ts[n - 2])
    k = min(max(_segment(ts, t), 1), n - 3)
    u = (t - ts[k]) / (ts[k + 1] - ts[k])
    idx = range(k - 1, k + 3)
    p = cubic_weights(u) @ P[list(idx)]
    Rs = [quat_to_R(Q[i]) for i in idx]
    R = Rs[0].copy()
    for j, bt in enumerate(cubic_cumulative_weights(u)):
        R = R @ so3_exp(bt * so3_log(Rs[j].T @ Rs[j + 1]))
    return p, R


def bernstein(u, n):
    """Weights of n control points (degree n-1), knot i in time order."""
    d = n - 1
    return np.array([comb(d, i, exact=True) * (1.0 - u) ** (d - i) * u ** i for i in range(n)])


def pose_bezier_quat_cartesian(knots, t):
    """DeblurGS 'quarternion_cartesian': p = sum b_i p_i;
    q = sum b_i q_i (raw components, no sign alignment), R = R(q/|q|)."""
    ts, P, Q = _knots(knots, 2)
    t = _check_time(t, ts[0], ts[-1])
    b = bernstein((t - ts[0]) / (ts[-1] - ts[0]), len(ts))
    q = b @ Q
    nq = np.linalg.norm(q)
    if nq < 1e-12:
        raise ValueError("blended quaternion vanishes (knots on opposite hemispheres)")
    return b @ P, quat_to_R(q / nq)


def pose_bezier_se3_sum(knots, t):
    """DeblurGS 'se3': T = Exp(sum b_i xi_i), xi_i = se3_log(T_i) = (V^-1 p_i, Log R_i)."""
    ts, P, Q = _knots(knots, 2)
    t = _check_time(t, ts[0], ts[-1])
    b = bernstein((t - ts[0]) / (ts[-1] - ts[0]), len(ts))
    xis = np.array([se3_log(to_matrix(P[i], quat_to_R(Q[i]))) for i in range(len(ts))])
    return from_matrix(se3_exp(b @ xis))


def pose_bezier_se3_product(knots, t, reference=None):
    """BAD-Gaussians: T = Exp(b_0 xi_0) Exp(b_1 xi_1) ... Exp(b_{n-1} xi_{n-1}),
    xi_i = se3_log(T_i).  With reference=(p, R) the knots are taken as absolute
    poses T_i = T_ref D_i and the product is formed on D_i = T_ref^-1 T_i, then
    T = T_ref (product), as BAD-Gaussians applies its knots to the c2w."""
    ts, P, Q = _knots(knots, 2)
    t = _check_time(t, ts[0], ts[-1])
    b = bernstein((t - ts[0]) / (ts[-1] - ts[0]), len(ts))
    Tref = np.eye(4) if reference is None else to_matrix(reference[0], reference[1])
    Tinv = np.linalg.inv(Tref)
    T = np.eye(4)
    for i in range(len(ts)):
        T = T @ se3_exp(b[i] * se3_log(Tinv @ to_matrix(P[i], quat_to_R(Q[i]))))
    return from_matrix(Tref @ T)


pose_bezier = pose_bezier_quat_cartesian
pose_bezier_se3 = pose_bezier_se3_sum


# ----------------------------------------------------------------------------
# self-tests
# ----------------------------------------------------------------------------


def _rng():
    return np.random.default_rng(20240912)


def _rand_knots(rng, n, dt=0.5, t0=2.0, rot=1.0, trans=1.0):
    ks = []
    for i in range(n):
        q = Rotation.from_rotvec(rng.normal(size=3) * rot).as_quat()
        ks.append((t0 + i * dt, rng.normal(size=3) * trans, q))
    return ks


def _close(a, b, tol=1e-9):
    return float(np.max(np.abs(np.asarray(a) - np.asarray(b)))) <= tol


def _same_pose(x, y, tol=1e-9):
    return _close(x[0], y[0], tol) and _close(x[1], y[1], tol)


def self_test_lie():
    rng = _rng()
    for _ in range(50):
        w = rng.normal(size=3)
        w *= rng.uniform(0.0, 3.1) / np.linalg.norm(w)
        xi = np.concatenate([rng.normal(size=3), w])
        T = se3_exp(xi)
        assert _close(T, expm(se3_hat(xi)), 1e-10)
        assert _close(se3_log(T), xi, 1e-9)
        L = np.real(logm(T))
        assert _close(np.concatenate([L[:3, 3], vee(L[:3, :3])]), xi, 1e-7)
        assert _close(so3_V_inv(w), np.linalg.inv(so3_V(w)), 1e-10)
        assert _close(so3_log(so3_exp(w)), Rotation.from_matrix(so3_exp(w)).as_rotvec(), 1e-9)
    for ang in (1e-9, 1e-5, 1e-3, math.pi - 1e-4, math.pi - 1e-7):   # edge angles
        w = ang * np.array([0.6, -0.8, 0.0])
        assert _close(so3_log(so3_exp(w)), w, 1e-8), ang
        assert _close(se3_exp(np.r_[1.0, 2.0, 3.0, w]), expm(se3_hat(np.r_[1.0, 2.0, 3.0, w])), 1e-10)


def self_test_endpoints():
    rng = _rng()
    ks = _rand_knots(rng, 5)
    for k in ks:
        T = (k[1], quat_to_R(k[2]))
        assert _same_pose(pose_linear(ks, k[0]), T)
        assert _same_pose(pose_se3(ks, k[0]), T)
    for f in (pose_bezier_quat_cartesian, pose_bezier_se3_sum, pose_bezier_se3_product):
        assert _same_pose(f(ks, ks[0][0]), (ks[0][1], quat_to_R(ks[0][2])))
        assert _same_pose(f(ks, ks[-1][0]), (ks[-1][1], quat_to_R(ks[-1][2])))
    ref = (rng.normal(size=3), quat_to_R(ks[2][2]))
    assert _same_pose(pose_bezier_se3_product(ks, ks[-1][0], ref), (ks[-1][1], quat_to_R(ks[-1][2])))
    for f, lo, hi in ((pose_linear, 0, -1), (pose_se3, 0, -1), (pose_cubic, 1, -2),
                      (pose_bezier, 0, -1), (pose_bezier_se3, 0, -1)):
        for bad in (ks[lo][0] - 1e-9, ks[hi][0] + 1e-9, float("nan")):
            try:
                f(ks, bad)
            except ValueError:
                continue
            raise AssertionError(f"{f.__name__} accepted t={bad}")
        f(ks, ks[lo][0])
        f(ks, ks[hi][0])


def self_test_linear():
    rng = _rng()
    ks = _rand_knots(rng, 3)
    ts = [k[0] for k in ks]
    for t in np.linspace(ts[0], ts[-1], 23):
        p, R = pose_linear(ks, t)
        k = _segment(np.array(ts), t)
        u = (t - ts[k]) / (ts[k + 1] - ts[k])
        Rk, Rk1 = quat_to_R(ks[k][2]), quat_to_R(ks[k + 1][2])
        assert _close(R, Rk @ so3_exp(u * so3_log(Rk.T @ Rk1)), 1e-9)
        assert _close(p, (1 - u) * ks[k][1] + u * ks[k + 1][1])
    # short arc: knot 1 is a 270 deg turn about z, stored with either sign
    q1 = Rotation.from_rotvec([0, 0, 1.5 * math.pi]).as_quat()
    for s in (1.0, -1.0):
        kk = [(0.0, np.zeros(3), np.array([0, 0, 0, 1.0])), (1.0, np.ones(3), s * q1)]
        _, R = pose_linear(kk, 0.5)
        assert _close(R, so3_exp([0, 0, -0.25 * math.pi]), 1e-12)   # -45 deg, not +135
    # quaternion sign is irrelevant for the Lie-group forms
    ks = _rand_knots(rng, 5)
    ks2 = [(t, p, -q) for (t, p, q) in ks]
    for f in (pose_linear, pose_se3, pose_cubic, pose_bezier_se3_sum, pose_bezier_se3_product):
        assert _same_pose(f(ks, 3.37), f(ks2, 3.37))


def self_test_screw():
    """Pure rotation by theta about axis a through c: T1 = [[R, (I-R)c], [0,1]].
    se3: p(u) = (I - Exp(u theta a)) c (arc); linear: p(u) = u (I-R) c (chord)."""
    a = np.array([0.0, 0.0, 1.0])
    c = np.array([2.0, 1.0, 0.5])
    theta = 1.2
    R1 = so3_exp(theta * a)
    kk = [(0.0, np.zeros(3), np.array([0, 0, 0, 1.0])),
          (1.0, (np.eye(3) - R1) @ c, Rotation.from_matrix(R1).as_quat())]
    r = np.linalg.norm(c[:2])
    for u in np.linspace(0.0, 1.0, 11):
        p, R = pose_se3(kk, u)
        assert _close(p, (np.eye(3) - so3_exp(u * theta * a)) @ c, 1e-12)
        assert abs(np.linalg.norm((p - c)[:2]) - r) < 1e-12 and abs(p[2]) < 1e-12
        pl, Rl = pose_linear(kk, u)
        assert _close(Rl, R, 1e-12)
        assert _close(pl, u * (np.eye(3) - R1) @ c, 1e-12)
    p, _ = pose_se3(kk, 0.5)
    pl, _ = pose_linear(kk, 0.5)
    sag = r * (1.0 - math.cos(theta / 2.0))          # arc-chord distance at mid
    assert abs(np.linalg.norm(p - pl) - sag) < 1e-12 and sag > 0.1
    return sag


def self_test_cubic():
    rng = _rng()
    n, dt, t0 = 7, 0.25, 1.0
    ks = _rand_knots(rng, n, dt=dt, t0=t0, rot=0.8)
    P = np.array([k[1] for k in ks])
    tau = t0 + dt * (np.arange(n + 4) - 2.0)          # uniform, clamps nothing
    spl = BSpline(tau, P, 3, extrapolate=False)
    for t in np.linspace(ks[1][0], ks[n - 2][0], 41):
        assert _close(pose_cubic(ks, t)[0], spl(t), 1e-12)
    # single axis: cumulative rotation spline == scalar B-spline of angles
    axis = rng.normal(size=3)
    axis /= np.linalg.norm(axis)
    ang = np.cumsum(rng.uniform(-2.5, 2.5, size=n))   # |steps| < pi, total may exceed pi
    kr = [(t0 + i * dt, P[i], Rotation.from_rotvec(ang[i] * axis).as_quat()) for i in range(n)]
    sa = BSpline(tau, ang, 3, extrapolate=False)
    for t in np.linspace(kr[1][0], kr[n - 2][0], 41):
        assert _close(pose_cubic(kr, t)[1], so3_exp(float(sa(t)) * axis), 1e-10)
    # general rotations: C0 continuity at the inner joins (fails for a swapped product order)
    for k in range(2, n - 2):
        tk = ks[k][0]
        left = pose_cubic(ks[:k + 2], tk)          # last segment of the shorter curve, u = 1
        right = pose_cubic(ks[k - 1:], tk)         # first segment of the later curve, u = 0
        assert _same_pose(left, right, 1e-12), k
    # hand-worked value at u = 0: R_{k-1} Exp(5/6 L1) Exp(1/6 L2)
    R = [quat_to_R(k[2]) for k in ks]
    _, R2 = pose_cubic(ks, ks[2][0])
    L1, L2 = so3_log(R[1].T @ R[2]), so3_log(R[2].T @ R[3])
    assert _close(R2, R[1] @ so3_exp(5 / 6 * L1) @ so3_exp(1 / 6 * L2), 1e-12)
    assert _close(cubic_weights(0.3).sum(), 1.0, 1e-15)
    assert _close(cubic_cumulative_weights(0.3), np.cumsum(cubic_weights(0.3)[::-1])[::-1][1:], 1e-15)
    try:
        pose_cubic([(0.0, *ks[0][1:]), (1.0, *ks[1][1:]), (2.5, *ks[2][1:]), (3.0, *ks[3][1:])], 1.5)
    except ValueError:
        pass
    else:
        raise AssertionError("non-uniform cubic knots accepted")


def self_test_bezier():
    rng = _rng()
    n = 5
    ks = _rand_knots(rng, n, dt=0.1, t0=0.0, rot=0.4)
    T0, T1 = ks[0][0], ks[-1][0]
    P = np.array([k[1] for k in ks])
    bp = BPoly(P[:, None, :], [T0, T1])
    # DeblurGS's own indexing: weight of ITS control point k is C(C,k) t^(C-k) (1-t)^k
    C = n - 1
    for u in (0.0, 0.3, 0.77, 1.0):
        dg = np.array([comb(C, k, exact=True) * u ** (C - k) * (1 - u) ** k for k in range(C + 1)])
        assert _close(dg[::-1], bernstein(u, n), 1e-15)
    for t in np.linspace(T0, T1, 9):
        assert _close(pose_bezier_quat_cartesian(ks, t)[0], bp(t), 1e-12)
    # identity rotations: se3 sum and product reduce to the plain Bezier of p
    ki = [(k[0], k[1], np.array([0, 0, 0, 1.0])) for k in ks]
    for t in np.linspace(T0, T1, 9):
        for f in (pose_bezier_se3_sum, pose_bezier_se3_product, pose_bezier_quat_cartesian):
            p, R = f(ki, t)
            assert _close(p, bp(t), 1e-12) and _close(R, np.eye(3), 1e-12)
    # commuting twists (rotation about z, translation along z): sum == product
    kz = [(k[0], np.array([0, 0, k[1][2]]), Rotation.from_rotvec([0, 0, 0.7 * i]).as_quat())
          for i, k in enumerate(ks)]
    for t in np.linspace(T0, T1, 9):
        assert _same_pose(pose_bezier_se3_sum(kz, t), pose_bezier_se3_product(kz, t), 1e-12)
    # hand-worked, non-commuting: knot 0 = translation a, knot 1 = turn theta about z.
    # product (knot 0 leftmost): p = (1-u) a, unrotated; sum: p = V(u theta z) (1-u) a
    a, th = np.array([1.0, 0.0, 0.3]), 1.1
    kh = [(0.0, a, np.array([0, 0, 0, 1.0])), (1.0, np.zeros(3), Rotation.from_rotvec([0, 0, th]).as_quat())]
    Tref = (np.array([0.2, -1.0, 3.0]), quat_to_R(ks[1][2]))
    kh_abs = [(t, Tref[1] @ p + Tref[0], (Rotation.from_matrix(Tref[1]) * Rotation.from_quat(q)).as_quat())
              for (t, p, q) in kh]
    for u in (0.25, 0.5, 0.9):
        Rz = so3_exp([0, 0, u * th])
        assert _same_pose(pose_bezier_se3_product(kh, u), ((1 - u) * a, Rz), 1e-12)
        assert _same_pose(pose_bezier_se3_product(kh_abs, u, Tref),
                          (Tref[1] @ ((1 - u) * a) + Tref[0], Tref[1] @ Rz), 1e-12)
        assert _same_pose(pose_bezier_se3_sum(kh, u), (so3_V([0, 0, u * th]) @ ((1 - u) * a), Rz), 1e-12)
    # general knots: the three forms differ at mid-exposure
    ps = pose_bezier_se3_sum(ks, 0.2)[0]
    pp_ = pose_bezier_se3_product(ks, 0.2)[0]
    pq = pose_bezier_quat_cartesian(ks, 0.2)[0]
    d = (np.linalg.norm(ps - pp_), np.linalg.norm(ps - pq))
    assert min(d) > 1e-3
    # quaternion sign matters for the per-component form only
    kflip = list(ks)
    kflip[2] = (ks[2][0], ks[2][1], -ks[2][2])
    assert not _same_pose(pose_bezier_quat_cartesian(ks, 0.2), pose_bezier_quat_cartesian(kflip, 0.2), 1e-6)
    return d


def run_all():
    self_test_lie()
    print("lie: se3_exp/log vs scipy expm/logm, V^-1, edge angles ... ok")
    self_test_endpoints()
    print("endpoints: knots reproduced, out-of-domain ValueError ... ok")
    self_test_linear()
    print("linear: R_k Exp(u Log), 270deg -> short arc, sign-invariant ... ok")
    sag = self_test_screw()
    print(f"screw: se3 on circle, linear on chord, mid gap {sag:.6f} = r(1-cos(theta/2)) ... ok")
    self_test_cubic()
    print("cubic: p vs scipy BSpline, 1-axis R vs BSpline(angles), C0 joins, u=0 value ... ok")
    d = self_test_bezier()
    print(f"bezier: p vs scipy BPoly, DeblurGS reversed index, sum==product when commuting; "
          f"|sum-product|={d[0]:.4f} |sum-quatcart|={d[1]:.4f} ... ok")


if __name__ == "__main__":
    run_all()
    print("all self-tests passed")
