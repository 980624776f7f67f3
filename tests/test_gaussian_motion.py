"""Motion blur of one 2DGS Gaussian: the time integral refrender estimates
(--pixel-filter point, sampled time, 32 batches) against a quadrature of
the numpy reference of the official forward pass (tests/gs2d_reference.py)
at 2000 instants of the shutter. Expectations: the pixel the Gaussian
crosses at mid-shutter agrees within k = 3 standard errors (its 32
batches' own) for every seed; and a Sobol' render of 2^16 times per pixel
agrees with the quadrature within 2e-5 at every pixel of the streak (the
midpoint rule's error at the few kinks, where the filter takes over or
alpha drops below 1/255, is below 1e-5 here; the render's standard error
below 1e-6), which no bias above that can pass.
The Gaussian moves (its object's animation) or the camera does (the
projection, and with it the low-pass filter, taken at each sample's
time); a sub-pixel Gaussian is seen only through the filter. Independent
of refrender's C: the reference was written from the paper and the
official CUDA source, the quadrature is a midpoint rule."""
import numpy as np
import pytest

import gs2d_reference as ref
import gsply
from conftest import read_full, run

W, H, F = 9, 5, 20.0
DEPTH = 4.0
BACKGROUND = np.array([0.1, 0.2, 0.3])
TRAVEL = 0.6  # world units over the shutter [0, 1]: three pixels at this depth
K = 3.0
QUAD = 2000


def model(scale):
    c, s = np.cos(0.4), np.sin(0.4)  # turned 0.8 rad about x: seen obliquely
    colour = np.array([0.9, 0.6, 0.2])
    return {"mean": np.zeros((1, 3)), "scale": np.array([[scale, 0.6 * scale]]), "rot": np.array([[c, s, 0, 0]]),
            "opacity": np.array([0.8]), "sh": ((colour - 0.5) / ref.SH_C0).reshape(1, 1, 3), "degree": 0}


def instant_items(m, mean, C, R=np.eye(3)):
    """The reference's splat of the Gaussian with its mean and the camera centre at one instant
    (camera axes R_c2w, by default x right, y down, z forward): the same for every pixel, so made
    once an instant."""
    T, depth = ref.splat_transform(mean, m["scale"][0], m["rot"][0], R, C, F, F, W, H)
    items = []
    if depth > 0.2:
        d = mean - C
        items.append((depth, 0, T, ref.projected_centre(T), ref.sh_to_rgb(m["sh"][0], 0, d / np.linalg.norm(d))))
    return items


def pixel_colour(m, mean, C, px, py, R=np.eye(3)):
    """The reference's colour of pixel centre (px, py) at one instant (see instant_items)."""
    return ref.shade_pixel(instant_items(m, mean, C, R), m, px, py, BACKGROUND)[0]


def row_colours(m, mean, C, R=np.eye(3)):
    """The reference's colours of the middle row's pixel centres at one instant."""
    items = instant_items(m, mean, C, R)
    return np.array([ref.shade_pixel(items, m, i + 0.5, H // 2 + 0.5, BACKGROUND)[0] for i in range(W)])


def quadrature(m, moving):
    """Per pixel of the middle row: the midpoint rule over the shutter (a(t) a box)."""
    start = np.array([-TRAVEL / 2, 0.013, DEPTH])
    out = np.zeros((W, 3))
    for k in range(QUAD):
        t = (k + 0.5) / QUAD
        shift = np.array([TRAVEL * t, 0, 0])
        mean, C = (start + shift, np.zeros(3)) if moving == "gaussian" else (start + [TRAVEL / 2, 0, 0], -shift
                                                                             + [TRAVEL / 2, 0, 0])
        out += row_colours(m, mean, C) / QUAD
    return out


def scene_xml(ply, moving):
    camera = gsply.camera_xml(np.eye(3), np.zeros(3), F, W, H)
    if moving == "gaussian":
        obj = (f'<object name="g" position="{-TRAVEL / 2} 0.013 {DEPTH}"><gaussianModel file="{ply}"/>'
               f'<animation><linear velocity="{TRAVEL} 0 0"/></animation></object>')
    else:  # the camera moves from +TRAVEL/2 to -TRAVEL/2 past a still Gaussian: the same relative motion
        camera = camera.replace("/>", f'><animation><linear velocity="{-TRAVEL} 0 0"/></animation></camera>')
        camera = camera.replace('position="0 0 0"', f'position="{TRAVEL / 2} 0 0"')
        camera = camera.replace('lookat="0 0 1"', f'lookat="{TRAVEL / 2} 0 1"')
        obj = f'<object name="g" position="0 0.013 {DEPTH}"><gaussianModel file="{ply}"/></object>'
    return f'<scene>{camera}<shutter open="0" close="1"/><background color="0.1 0.2 0.3"/>{obj}</scene>'


@pytest.mark.parametrize("scale", [0.15, 0.004])  # larger than a pixel (0.2 units here); far smaller
@pytest.mark.parametrize("moving", ["gaussian", "camera"])
def test_the_time_integral_of_a_moving_gaussian_is_the_quadrature(tmp_path, scale, moving):
    m = model(scale)
    ply = tmp_path / "g.ply"
    gsply.write(ply, m)
    scene = tmp_path / "scene.xml"
    scene.write_text(scene_xml(ply, moving))
    expect = quadrature(gsply.read(ply), moving)
    assert np.ptp(expect[:, 0]) > 0.05  # the blur streak is there
    _check_integral(tmp_path, scene, expect)


TURN = 16.0  # degrees over the shutter about world y: the Gaussian's image sweeps about 5.6 pixels


def turned_y(degrees):
    a = np.radians(degrees)
    return np.array([[np.cos(a), 0, np.sin(a)], [0, 1, 0], [-np.sin(a), 0, np.cos(a)]])


def turning_quadrature(m, mean):
    """The middle row's midpoint rule under a camera at the origin turning about world y from -TURN/2
    to TURN/2 (refrender's rotation animation: right-handed, angle = rate x t, after the rest pose)."""
    out = np.zeros((W, 3))
    for k in range(QUAD):
        R = turned_y(TURN * ((k + 0.5) / QUAD - 0.5))
        out += row_colours(m, mean, np.zeros(3), R) / QUAD
    return out


def test_the_time_integral_under_a_turning_camera_is_the_quadrature(tmp_path):
    """A sub-pixel 2DGS Gaussian (seen through the filter) under a camera turning in place, looking
    along world z at mid-shutter: the footprint lies across the view axis of each instant, and the
    boxes are flattened along the mid-shutter axis with the camera's turn as a cone (boxes flattened
    along another axis fail this and 16 other Gaussian tests; the cone's own sharp check is
    test_gaussian_hit.c's, which a zero cone fails: here a window's traversal meets the box
    elsewhere along the ray). Same checks as above."""
    m = model(0.004)
    ply = tmp_path / "g.ply"
    gsply.write(ply, m)
    mean = np.array([0.0, 0.013, DEPTH])
    camera = gsply.camera_xml(turned_y(-TURN / 2), np.zeros(3), F, W, H).replace(
        "/>", f'><animation><rotation axis="0 1 0" degrees_per_unit_time="{TURN}"/></animation></camera>')
    scene = tmp_path / "scene.xml"
    scene.write_text(f'<scene>{camera}<shutter open="0" close="1"/><background color="0.1 0.2 0.3"/>'
                     f'<object name="g" position="0 0.013 {DEPTH}"><gaussianModel file="{ply}"/></object></scene>')
    expect = turning_quadrature(gsply.read(ply), mean)
    assert np.ptp(expect[:, 0]) > 0.05
    _check_integral(tmp_path, scene, expect)


def _check_integral(tmp_path, scene, expect):
    """The middle row's pixel at mid-shutter within K standard errors for seeds 1-4 (32 batches of 256
    times), and the whole row within 2e-5 of the quadrature at 2^16 Sobol' times (16 batches of 4096),
    whose standard error, below 1e-6, is checked: its error against the quadrature is below 1e-6 on
    the 2DGS cases, as at 2^18, so no bias of 2e-5 and more passes."""
    row, mid = H // 2, W // 2
    for seed in range(1, 5):
        ch = _render(tmp_path, scene, seed, "thesis", 256, 32)
        for c, name in enumerate("RGB"):
            got, se = ch[name][row, mid], ch[f"stderr.{name}"][row, mid]
            assert abs(got - expect[mid, c]) < K * se, (seed, name, got, expect[mid, c], se)
    ch = _render(tmp_path, scene, 1, "sobol", 4096, 16)
    for c, name in enumerate("RGB"):
        assert ch[f"stderr.{name}"][row].max() < 1e-6, (name, ch[f"stderr.{name}"][row])
        assert np.abs(ch[name][row] - expect[:, c]).max() < 2e-5, (name, ch[name][row], expect[:, c])


def _render(tmp_path, scene, seed, sampler, tspp, batches, *extra):
    """Only the middle row, which the checks read (a crop window: a fifth of the work)."""
    out = tmp_path / f"out{seed}{sampler}{'_'.join(extra)}.exr"
    proc = run([scene, "--pixel-filter", "point", "--spp", 1, "--tspp", tspp, "--batches", batches, "--seed", seed,
                "--sampler", sampler, "--crop-window", f"0,1,{(H // 2) / H},{(H // 2 + 1) / H}", "-o", out, "--quiet",
                *extra])
    assert proc.returncode == 0, proc.stderr
    ch, header = read_full(out)
    # the window's row, at index H // 2 of a full-size array
    rows = {name: np.full((H, W), np.nan, dtype=np.float32) for name in ch}
    for name, v in ch.items():
        assert v.shape == (1, W), v.shape
        rows[name][H // 2] = v[0]
    return rows


def srgb_to_linear(v):
    """IEC 61966-2-1's decoding of values clamped to [0, 1]."""
    v = np.clip(v, 0, 1)
    return np.where(v <= 0.04045, v / 12.92, ((v + 0.055) / 1.055) ** 2.4)


def test_blur_space_linear_decodes_each_instant_before_the_time_average(tmp_path):
    """--blur-space linear: the pixel is the time average of the decoded colours (as benchmarks that
    average linear frames), not the decoded average; the EXR says which."""
    m = model(0.15)
    ply = tmp_path / "g.ply"
    gsply.write(ply, m)
    scene = tmp_path / "scene.xml"
    scene.write_text(scene_xml(ply, "gaussian"))
    start = np.array([-TRAVEL / 2, 0.013, DEPTH])
    read = gsply.read(ply)
    expect = np.zeros(3)
    for k in range(QUAD):
        mean = start + [TRAVEL * (k + 0.5) / QUAD, 0, 0]
        expect += srgb_to_linear(pixel_colour(read, mean, np.zeros(3), W // 2 + 0.5, H // 2 + 0.5)) / QUAD
    ch = _render(tmp_path, scene, 1, "sobol", 4096, 16, "--blur-space", "linear")
    assert read_full(tmp_path / "out1sobol--blur-space_linear.exr")[1]["refrender:blurSpace"] == "linear"
    model_space = _render(tmp_path, scene, 1, "sobol", 4096, 16)
    decoded_average = np.zeros(3)
    for c, name in enumerate("RGB"):
        got = ch[name][H // 2, W // 2]
        assert abs(got - expect[c]) < 2e-5, (name, got, expect[c])
        decoded_average[c] = srgb_to_linear(model_space[name][H // 2, W // 2])
    assert np.abs(decoded_average - expect).max() > 10 * 2e-5  # decoding the average instead fails


def _write_3d(tmp_path, middle_scale):
    """One 3D Gaussian at the origin turned 0.6 rad about y (its object places it), as g3.ply."""
    c, s = np.cos(0.3), np.sin(0.3)
    colour = np.array([0.3, 0.8, 0.5])
    m = {"mean": np.zeros((1, 3)), "scale": np.array([[0.12, middle_scale, 0.2]]), "rot": np.array([[c, 0, s, 0]]),
         "opacity": np.array([0.85]), "sh": ((colour - 0.5) / ref.SH_C0).reshape(1, 1, 3), "degree": 0}
    ply = tmp_path / "g3.ply"
    gsply.write(ply, m)
    return ply


def test_the_time_integral_of_a_moving_3dgrt_gaussian_is_the_quadrature(tmp_path):
    """The same for a 3D Gaussian with 3DGRT's rules (tests/gs3d_grt_reference.py): its object moves
    across the middle row; k = 3 standard errors for every seed, 2e-5 at 2^16 Sobol' times."""
    import gs3d_grt_reference as grt
    ply = _write_3d(tmp_path, 0.07)
    camera = gsply.camera_xml(np.eye(3), np.zeros(3), F, W, H)
    scene = tmp_path / "scene3.xml"
    scene.write_text(f'<scene>{camera}<shutter open="0" close="1"/><background color="0.1 0.2 0.3"/>'
                     f'<object name="g" position="{-TRAVEL / 2} 0.013 {DEPTH}">'
                     f'<gaussianModel file="{ply}" semantics="3dgrt"/>'
                     f'<animation><linear velocity="{TRAVEL} 0 0"/></animation></object></scene>')
    read = gsply.read(ply)
    row = H // 2
    expect = np.zeros((W, 3))
    for k in range(QUAD):
        moved = dict(read, mean=read["mean"] + [-TRAVEL / 2 + TRAVEL * (k + 0.5) / QUAD, 0.013, DEPTH])
        for i in range(W):
            org, d = grt.pixel_ray(np.eye(3), np.zeros(3), F, F, W, H, i + 0.5, row + 0.5)
            expect[i] += grt.trace(moved, org, d, BACKGROUND)[0] / QUAD
    assert np.ptp(expect[:, 1]) > 0.05
    _check_integral(tmp_path, scene, expect)


@pytest.mark.parametrize("moving", ["gaussian", "camera"])
def test_the_time_integral_of_a_moving_rasterized_3dgs_gaussian_is_the_quadrature(tmp_path, moving):
    """A 3D Gaussian under the graphdeco-inria rasterizer's semantics (the default for 3D models;
    tests/gs3d_raster_reference.py), its object or the camera moving: the EWA footprint, its clamp and
    dilation taken with the camera of each instant. k = 3 standard errors for every seed, 2e-5 at
    2^16 Sobol' times."""
    import gs3d_raster_reference as raster
    ply = _write_3d(tmp_path, 0.05)
    scene = tmp_path / "scene3.xml"
    scene.write_text(scene_xml(ply, moving))
    read = gsply.read(ply)
    start = np.array([-TRAVEL / 2, 0.013, DEPTH])
    expect = np.zeros((W, 3))
    for k in range(QUAD):
        shift = np.array([TRAVEL * (k + 0.5) / QUAD, 0, 0])
        mean, C = (start + shift, np.zeros(3)) if moving == "gaussian" else (start + [TRAVEL / 2, 0, 0],
                                                                             [TRAVEL / 2, 0, 0] - shift)
        img = raster.render(dict(read, mean=read["mean"] + mean), np.eye(3), C, F, F, W, H, BACKGROUND)[0]
        expect += img[H // 2] / QUAD
    assert np.ptp(expect[:, 1]) > 0.05
    _check_integral(tmp_path, scene, expect)
