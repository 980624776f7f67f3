#!/usr/bin/python3
"""An independent reference of Guan and Mueller's motion hints (Point-based
surface rendering with motion blur, SPBG 2004; ../shared/seeds/), written
from the paper alone, for scenes of a few circular splats under <linear>
or <rotation> motion, a still pinhole camera and unlit materials. Camera,
motion formulas and the ray/disk crossing are those of
splat_volumetric_reference.py (numpy, no refrender code); the rest is here.

The paper's method, as read here (src/SPLAT.md gives the same reading):
- the flash (sec. 3.1, 4): the object is captured sharp at the end of the
  exposure, the current frame; each point's motion vector runs from its
  position in the previous frame (the shutter's open) to the current one
  (its close): motion = M_curr p - M_prev p;
- the object (sec. 3.2): every point a round Gaussian disk on its normal's
  plane (a texture-mapped square, so the Gaussian is read where the pixel's
  ray meets the plane), alpha exp(-rho^2 / (2 sigma^2)) inside the disk
  (rho the distance from the centre in radii), bucket-sorted by distance
  from the viewpoint and alpha-composited front to back;
- one trail splat per point (sec. 3.3, the "more efficient method"): the
  screen-space 2D variance-covariance matrix of the disk (its 3D matrix,
  zero along the normal, through the projection's Jacobian, last row and
  column dropped) plus the rank-1 matrix of the projected motion vector
  (an ellipse of zero width spanning the vector: (m/2)(m/2)^T), centred at
  the vector's middle (Fig. 3-4), read as the same Gaussian texture over
  the summed ellipse; the low-pass keeps a point's integral, so its peak
  is sqrt(det V_disk / det V); none for points whose normals face away
  from the viewer (sec. 4);
- the two images (sec. 4): the trails either added (sum of g c, alpha the
  clamped sum of g) or alpha-blended front to back by the depth of the
  vector's middle ('blend'); the object image composited over the motion
  image, that over the background.
"""
import math

import numpy as np

from splat_volumetric_reference import camera_rays, project, ray_ellipse, splat_at


def pixel_jacobian(eye, frame, width, height, p):
    """d(pixel x, pixel y) / d(world point) of project() at p (2 x 3)."""
    right, upv, fwd, th = frame
    q = p - eye
    z = q @ fwd
    aspect = width / height
    dx = (right / z - (q @ right) * fwd / z ** 2) / (th * aspect) * width / 2
    dy = -(upv / z - (q @ upv) * fwd / z ** 2) / th * height / 2
    return np.stack([dx, dy])


def object_image(sc, eye, dirs, frame, t):
    """The sharp object at t: premultiplied RGB and alpha per pixel."""
    H, W = dirs.shape[:2]
    sigma = sc['sigma']
    placed = [(splat_at(sp, sp['motion'], t), sp) for sp in sc['splats']]
    placed.sort(key=lambda e: (e[0][0] - eye) @ frame[2])
    rgb, trans = np.zeros((H, W, 3)), np.ones((H, W))
    for (c, a0, a1, n, _), sp in placed:
        r = sp['radius']
        for y in range(H):
            for x in range(W):
                s = ray_ellipse(eye, dirs[y, x], c, a0, a1, n, r)
                if s is None:
                    continue
                q = eye + s * dirs[y, x] - c
                rho2 = ((q @ a0) ** 2 + (q @ a1) ** 2) / r ** 4
                a = math.exp(-rho2 / (2 * sigma * sigma))
                rgb[y, x] += trans[y, x] * a * np.asarray(sp['color'], float)
                trans[y, x] *= 1 - a
    return rgb, 1 - trans


def trail_splats(sc, eye, frame, W, H):
    """Per front-facing point: (depth of the vector's middle, centre, V^-1,
    peak, colour) of its trail at the shutter's close."""
    t0, t1 = sc['shutter']
    out = []
    for sp in sc['splats']:
        c0 = splat_at(sp, sp['motion'], t0)[0]
        c1, a0, a1, n, _ = splat_at(sp, sp['motion'], t1)
        if n @ (eye - c1) <= 0:
            continue  # back-facing: no motion splat (sec. 4)
        p0, p1 = np.array(project(eye, frame, W, H, c0)), np.array(project(eye, frame, W, H, c1))
        J = pixel_jacobian(eye, frame, W, H, c1)
        v_disk = J @ (np.outer(a0, a0) + np.outer(a1, a1)) @ J.T
        half = (p1 - p0) / 2
        v = v_disk + np.outer(half, half)
        if np.linalg.det(v_disk) <= 1e-12 * np.trace(v_disk) ** 2:
            continue  # edge-on: no footprint to blur
        peak = math.sqrt(np.linalg.det(v_disk) / np.linalg.det(v))
        out.append(((0.5 * (c0 + c1) - eye) @ frame[2], (p0 + p1) / 2, np.linalg.inv(v), peak,
                    np.asarray(sp['color'], float)))
    return out


def motion_image(sc, eye, frame, W, H, trails):
    sigma = sc['sigma']
    rgb, alpha_sum, trans = np.zeros((H, W, 3)), np.zeros((H, W)), np.ones((H, W))
    ys, xs = np.mgrid[0:H, 0:W]
    centres = np.stack([xs + 0.5, ys + 0.5], axis=-1)
    for _, mu, vinv, peak, col in sorted(trail_splats(sc, eye, frame, W, H), key=lambda e: e[0]):
        d = centres - mu
        rho2 = np.einsum('hwi,ij,hwj->hw', d, vinv, d)
        g = np.where(rho2 <= 1, peak * np.exp(-rho2 / (2 * sigma * sigma)), 0.0)
        if trails == 'add':
            rgb += g[..., None] * col
            alpha_sum += g
        else:
            rgb += (trans * g)[..., None] * col
            trans *= 1 - g
    return rgb, (np.minimum(alpha_sum, 1) if trails == 'add' else 1 - trans)


def render(sc, trails='blend'):
    cam = sc['camera']
    W, H = cam['width'], cam['height']
    eye, dirs, frame = camera_rays(cam['position'], cam['lookat'], cam['up'], cam['fov'], W, H)
    o_rgb, o_a = object_image(sc, eye, dirs, frame, sc['shutter'][1])
    m_rgb, m_a = motion_image(sc, eye, frame, W, H, trails)
    bg = np.asarray(sc['background'], float)
    rgb = o_rgb + (1 - o_a)[..., None] * (m_rgb + (1 - m_a)[..., None] * bg)
    return np.concatenate([rgb, (o_a + (1 - o_a) * m_a)[..., None]], axis=-1)
