"""A numpy reference of 3D Gaussian ray tracing with 3DGRT's rules
(Moenne-Loccoz et al. 2024, "3D Gaussian Ray Tracing"; nv-tlabs/3dgrut:
threedgrt_tracer/include/3dgrt/kernels/slang/models/gaussianParticles.slang
for a hit, kernels/cuda/3dgrtTracer.cuh traceVolumetricGS for the loop,
configs/render/3dgrt.yaml for the constants), per ray, in float64, for
refrender's 3DGS ray-tracing tests:

- the ray in the Gaussian's canonical frame: o' = S^-1 R^T (o - mu),
  d' = S^-1 R^T d, and d'' = d' / |d'|;
- kernel degree 2 ('particle_kernel_degree: 2'; the config's default is 4,
  exp(-0.0556 r^4), another model): response = exp(-0.5 |d'' x o'|^2);
- alpha = min(0.99, opacity response), a hit only when response > 0.0113
  and alpha > 1/255 (both strict), at the distance t* = -(o'.d') / |d'|^2
  of the closest approach along the ray (world units for a unit d), which
  must be positive; the squared canonical distance below 9 (always so
  when the response is above 0.0113);
- hits in order of t*, composited C += T alpha c, T *= 1 - alpha while
  T > 0.001 (min_transmittance; the hit that crosses it is composited);
- colour: SH in the ray's direction, + 0.5, clamped below at 0.

Written from those sources and the paper, not from refrender's C."""
import numpy as np

import gs2d_reference as ref2d

MIN_RESPONSE = 0.0113
MIN_ALPHA = 1.0 / 255.0
MAX_ALPHA = 0.99
MIN_TRANSMITTANCE = 0.001


def hits(model, org, d):
    """(t*, index, alpha) of every accepted hit of the ray org + t d (d unit)."""
    out = []
    for i in range(len(model["opacity"])):
        R = ref2d.quat_to_rot(model["rot"][i])
        inv_s = 1.0 / np.asarray(model["scale"][i], float)
        o = inv_s * (R.T @ (np.asarray(org, float) - model["mean"][i]))
        dc = inv_s * (R.T @ np.asarray(d, float))
        t = -np.dot(o, dc) / np.dot(dc, dc)
        dn = dc / np.linalg.norm(dc)
        # dn x o, written out (np.cross's own products and differences, without its array overhead)
        c = np.array((dn[1] * o[2] - dn[2] * o[1], dn[2] * o[0] - dn[0] * o[2], dn[0] * o[1] - dn[1] * o[0]))
        dist2 = np.dot(c, c)
        response = np.exp(-0.5 * dist2)
        alpha = min(MAX_ALPHA, model["opacity"][i] * response)
        if response > MIN_RESPONSE and alpha > MIN_ALPHA and t > 0 and dist2 < 9:
            out.append((t, i, alpha))
    return sorted(out)


def trace(model, org, d, background):
    """(rgb, final transmittance) of one ray."""
    colour, T = np.zeros(3), 1.0
    for _, i, alpha in hits(model, org, d):
        if not T > MIN_TRANSMITTANCE:
            break
        colour += T * alpha * ref2d.sh_to_rgb(model["sh"][i], model["degree"], d)
        T *= 1 - alpha
    return colour + T * np.asarray(background, float), T


def pixel_ray(R_c2w, C, fx, fy, W, H, x, y):
    """The ray through raster (x, y) (pixel (i, j) covers [i, i+1] x [j, j+1]) of an OpenCV camera."""
    d = np.asarray(R_c2w, float) @ np.array([(x - W / 2) / fx, (y - H / 2) / fy, 1.0])
    return np.asarray(C, float), d / np.linalg.norm(d)


def render(model, R_c2w, C, fx, fy, W, H, background):
    img, tr = np.zeros((H, W, 3)), np.ones((H, W))
    for j in range(H):
        for i in range(W):
            org, d = pixel_ray(R_c2w, C, fx, fy, W, H, i + 0.5, j + 0.5)
            img[j, i], tr[j, i] = trace(model, org, d, background)
    return img, tr
