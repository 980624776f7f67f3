#!/usr/bin/python3
"""An independent reference of the volumetric kernels of Wolf 2008 (thesis
sec. 3.6.3, 4.1.2, 4.2.2, Appendix C), written from the thesis text and
src/SPLAT.md's stated readings only, for scenes of a few circular splats
under <linear> or <rotation> motion (the motion formulas are scenes/README's,
written out here), a still pinhole camera and unlit materials. It shares no
code with refrender: the camera, the kernel's quadric, the ray crossing, the
weights and the source-point depth test are computed here from their
definitions, in float64.

The method per pixel centre, N instants t_k = open + (k + 1/2) / N (close - open):
- each splat at t_k: centre c, axes a0, a1 (radius r, perpendicular to n),
  instantaneous velocity v (linear: the velocity; rotation: w x (c - centre));
- the kernel (App. C, 3.6.3): the splat's 2D Gaussian convolved with a 1D
  Gaussian along v: covariance sum S = a0 a0^T + a1 a1^T + w w^T +
  (1e-3 r)^2 n n^T, w = v dt sigma_t / sigma (dt = (close - open) / N: the
  slice a kernel stands for; sigma_t its standard deviation in units of
  |v| dt; sigma the kernel sigma in splat radii); the support is the
  ellipsoid x^T S^-1 x <= 1 about c (the n n^T term: C.3.1-C.3.2's
  epsilon n, so a still splat is a thin ellipsoid);
- a ray meets it in a chord [s1, s2]; its midpoint m in parameter space
  (|m|^2 = (x_mid - c)^T S^-1 (x_mid - c)) gives the weight h(|m|) =
  exp(-|m|^2 / (2 sigma^2)) (sec. 4.1.2: "transforming the intersection
  midpoint to parameter space and insert it into a 3D Gaussian"), which
  grows with the chord as sec. 4.2.2 asks (|m|^2 = 1 - (L/2)^2);
- the temporal density rho = sqrt(det(P S0 P^T) / det(P S P^T)), S0 = S
  without w w^T, P the projection onto the plane normal to the ray: the
  kernel's projected footprint holds the still splat's weight once
  ("the intensity integral of a kernel is constant independent of the
  length in time", sec. 4.2.2);
- depth test (sec. 4.1.2, eqs. 4.1, C.42-C.44): per instant a depth buffer
  of the 2D splats at the pixel centres (ray/ellipse crossings, the
  closest distance); the chord midpoint's source point o on the splat is
  its splat part in the kernel's parameter space (source_point; eq.
  C.44's trace-back along v where v crosses the plane, and still on the
  splat where v lies in or near the plane, with no threshold on v.n),
  and the fragment passes when |o - eye| <=
  depth(pixel of o) + epsilon, or that pixel holds no depth or lies
  outside the image;
- colour: sum a_k h c / sum a_k h over every passing fragment (a weighted
  average, Fig. 4.6); alpha 'thesis': sum_k a_k / sum a * sum_f h rho,
  clamped to [0, 1] (a weighted sum, sec. 4.1.2); 'normalized' (sec. 6.2):
  sum_k a_k / sum a * (sum_f h rho / sum_f h); the pixel is alpha C +
  (1 - alpha) background.
"""
import math

import numpy as np


def camera_rays(position, lookat, up, fov, width, height):
    """Unit ray directions through the pixel centres (a pinhole, vertical
    fov in degrees, raster (0, 0) the top-left corner, rows downward)."""
    eye = np.asarray(position, float)
    fwd = np.asarray(lookat, float) - eye
    fwd /= np.linalg.norm(fwd)
    right = np.cross(fwd, np.asarray(up, float))
    right /= np.linalg.norm(right)
    upv = np.cross(right, fwd)
    th = math.tan(math.radians(fov) / 2)
    xs = ((np.arange(width) + 0.5) / width * 2 - 1) * th * width / height
    ys = (1 - (np.arange(height) + 0.5) / height * 2) * th
    d = fwd + xs[None, :, None] * right + ys[:, None, None] * upv
    return eye, d / np.linalg.norm(d, axis=-1, keepdims=True), (right, upv, fwd, th)


def project(eye, frame, width, height, p):
    right, upv, fwd, th = frame
    q = p - eye
    z = q @ fwd
    if z <= 0:
        return None
    x = (q @ right) / z / (th * width / height)
    y = (q @ upv) / z / th
    return (x + 1) / 2 * width, (1 - y) / 2 * height


def rot_matrix(axis, deg):
    a = np.asarray(axis, float)
    a /= np.linalg.norm(a)
    t = math.radians(deg)
    K = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + math.sin(t) * K + (1 - math.cos(t)) * K @ K


def splat_at(sp, motion, t):
    """Centre, axes, normal and velocity of a circular splat at time t under
    scenes/README's <linear velocity> or <rotation axis center
    degrees_per_unit_time> (rotate by w t about the axis, then translate)."""
    c, n, r = (np.asarray(sp[k], float) for k in ('center', 'normal', 'radius'))
    n = n / np.linalg.norm(n)
    helper = np.array([1.0, 0, 0]) if abs(n[0]) < 0.9 else np.array([0, 1.0, 0])
    a0 = np.cross(n, helper)
    a0 *= r / np.linalg.norm(a0)
    a1 = np.cross(n, a0)
    a1 *= r / np.linalg.norm(a1)
    if motion['kind'] == 'linear':
        vel = np.asarray(motion['velocity'], float)
        return c + vel * t, a0, a1, n, vel
    R = rot_matrix(motion['axis'], motion['degrees'] * t)
    ctr = np.asarray(motion['center'], float)
    pos = ctr + R @ (c - ctr)
    omega = np.asarray(motion['axis'], float) / np.linalg.norm(motion['axis']) * math.radians(motion['degrees'])
    return pos, R @ a0, R @ a1, R @ n, np.cross(omega, pos - ctr)


def ray_ellipse(eye, d, c, a0, a1, n, r):
    """Distance along the ray to the splat plane when the crossing lies in
    the ellipse (eq. 4.2), else None."""
    den = d @ n
    if den == 0:
        return None
    s = ((c - eye) @ n) / den
    if s < 0:
        return None
    q = eye + s * d - c
    u, v = q @ a0 / (r * r), q @ a1 / (r * r)
    return s if u * u + v * v <= 1 else None


def source_point(q, c, a0, a1, w, thick):
    """The point of the 2D splat that generated the kernel point c + q
    (App. C.5-C.6: "each point in the interior of the volumetric kernel lies
    on the motion trail of its 2D splat source point"). The kernel is the
    image of the unit ball under the axes (a0, a1, w, thick): q = alpha a0 +
    beta a1 + tau w + delta thick. Of the coefficient vectors that give q,
    the shortest is q's own parameter-space position (its length is the
    |m| of the weight); the source is its splat part c + alpha a0 + beta a1,
    on the splat's plane and, inside the kernel, inside the splat, whatever
    the direction of w (in the plane, near it, or across it). Where w
    crosses the plane by far more than the thickness this is eq. C.44's
    trace-back along v (to within the thickness's share)."""
    axes = np.stack([a0, a1, w, thick], axis=1)
    coef = np.linalg.lstsq(axes, q, rcond=None)[0]
    return c + coef[0] * a0 + coef[1] * a1


def render(scene, n_instants, alpha='thesis', sigma_t=1 / math.sqrt(12)):
    cam = scene['camera']
    W, H = cam['width'], cam['height']
    eye, dirs, frame = camera_rays(cam['position'], cam['lookat'], cam['up'], cam['fov'], W, H)
    sigma, eps, bg = scene['sigma'], scene['epsilon'], np.asarray(scene['background'], float)
    t0, t1 = scene['shutter']
    dt = (t1 - t0) / n_instants
    col_sum = np.zeros((H, W, 3))
    w_sum = np.zeros((H, W))
    alpha_acc = np.zeros((H, W))
    for k in range(n_instants):
        t = t0 + (k + 0.5) * dt
        placed = [(splat_at(sp, sp['motion'], t), sp) for sp in scene['splats']]
        depth = np.full((H, W), np.inf)
        for (c, a0, a1, n, _), sp in placed:
            for y in range(H):
                for x in range(W):
                    s = ray_ellipse(eye, dirs[y, x], c, a0, a1, n, sp['radius'])
                    if s is not None and s < depth[y, x]:
                        depth[y, x] = s
        num = np.zeros((H, W))
        den = np.zeros((H, W))
        for (c, a0, a1, n, vel), sp in placed:
            r = sp['radius']
            w = vel * dt * sigma_t / sigma
            S0 = np.outer(a0, a0) + np.outer(a1, a1) + (1e-3 * r) ** 2 * np.outer(n, n)
            S = S0 + np.outer(w, w)
            Si = np.linalg.inv(S)
            for y in range(H):
                for x in range(W):
                    d = dirs[y, x]
                    oc = eye - c
                    A, B, C = d @ Si @ d, d @ Si @ oc, oc @ Si @ oc - 1
                    disc = B * B - A * C
                    if disc < 0:
                        continue
                    s1, s2 = (-B - math.sqrt(disc)) / A, (-B + math.sqrt(disc)) / A
                    if s2 < 0:
                        continue
                    xm = eye + 0.5 * (s1 + s2) * d
                    m2 = (xm - c) @ Si @ (xm - c)
                    h = math.exp(-m2 / (2 * sigma * sigma))
                    src = source_point(xm - c, c, a0, a1, w, (1e-3 * r) * n)
                    pw = project(eye, frame, W, H, src)
                    if pw is not None:
                        px, py = int(math.floor(pw[0])), int(math.floor(pw[1]))
                        if 0 <= px < W and 0 <= py < H and np.isfinite(depth[py, px]) \
                                and np.linalg.norm(src - eye) > depth[py, px] + eps:
                            continue
                    e1 = np.cross(d, [1.0, 0, 0] if abs(d[0]) < 0.9 else [0, 1.0, 0])
                    e1 /= np.linalg.norm(e1)
                    P = np.stack([e1, np.cross(d, e1)])
                    rho = math.sqrt(np.linalg.det(P @ S0 @ P.T) / np.linalg.det(P @ S @ P.T))
                    col_sum[y, x] += h * np.asarray(sp['color'], float)
                    w_sum[y, x] += h
                    num[y, x] += h * rho
                    den[y, x] += h
        if alpha == 'thesis':
            alpha_acc += num / n_instants
        else:
            alpha_acc += np.where(den > 0, num / np.where(den > 0, den, 1), 0) / n_instants
    a = np.clip(alpha_acc, 0, 1) if alpha == 'thesis' else alpha_acc
    colour = np.where(w_sum[..., None] > 0, col_sum / np.where(w_sum > 0, w_sum, 1)[..., None], 0)
    rgb = a[..., None] * colour + (1 - a[..., None]) * bg
    return np.concatenate([rgb, a[..., None]], axis=-1)


def scene_xml(scene):
    """The same scene as refrender reads it."""
    cam = scene['camera']
    objs = []
    for i, sp in enumerate(scene['splats']):
        m = sp['motion']
        if m['kind'] == 'linear':
            anim = '<linear velocity="%r %r %r"/>' % tuple(float(x) for x in m['velocity'])
        else:
            anim = '<rotation axis="%g %g %g" center="%g %g %g" degrees_per_unit_time="%r"/>' % (
                *m['axis'], *m['center'], m['degrees'])
        objs.append('<object name="s%d"><pointModel><splat center="%g %g %g" normal="%g %g %g" radius="%r" '
                    'color="%g %g %g"/></pointModel><material shading="unlit"/><animation>%s</animation></object>'
                    % (i, *sp['center'], *sp['normal'], sp['radius'], *sp['color'], anim))
    return ('<scene><camera position="%g %g %g" lookat="%g %g %g" up="%g %g %g" fov="%r" width="%d" height="%d"/>'
            % (*cam['position'], *cam['lookat'], *cam['up'], cam['fov'], cam['width'], cam['height'])
            + '<shutter open="%r" close="%r"/>' % tuple(scene['shutter'])
            + '<background color="%g %g %g"/>' % tuple(scene['background'])
            + '<render epsilon="%r" kernel_sigma="%r"/>' % (scene['epsilon'], scene['sigma'])
            + ''.join(objs) + '</scene>')
