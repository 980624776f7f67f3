#!/usr/bin/python3
"""refrender splat (src/SPLAT.md): the thesis's splatting methods as
comparands. Each check's expectation comes from another computation than
the one judged: the ray tracer (instant = --time T --pixel-filter point),
the N-frame average of the instants (accum), accumulation itself (bucket
with B = N) and the coverage of the truth (bucket's opaque smear)."""
import random

import numpy as np
import pytest

from conftest import ROOT, run, read_exr

SUITE = ['sphere_weights_box', 'sphere_weights_linear', 'sphere_weights_exp', 'diagonal', 'rotation',
         'towards_camera', 'crossing', 'thin_fast', 'camera_pan', 'large']
RES = '48x36'
# the EXR stores each batch estimate rounded to 2^-24 (film.h) and both
# sides sum their kernel weights in another order: a few float ulps
ROUNDING = 1e-6


def splat(args, out):
    proc = run(['splat', *args, '-o', out, '--quiet'])
    assert proc.returncode == 0, proc.stderr
    return read_exr(out)


def truth_instant(scene, t, out, res=RES):
    proc = run([scene, '--time', t, '--pixel-filter', 'point', '--spp', 1, '--res', res, '-o', out, '--quiet'])
    assert proc.returncode == 0, proc.stderr
    return read_exr(out)[0]


@pytest.mark.parametrize('name', SUITE)
def test_instant_equals_the_ray_tracer_at_pixel_centres(tmp_path, name):
    """Thesis 4.1.1 with 4.2.1's ray/ellipse test and no EWA filter computes,
    per pixel centre, the function the ray tracer samples there (issue 51's
    first check): the same crossing, kernel, epsilon rule and Phong."""
    scene = ROOT / 'scenes' / f'{name}.xml'
    # large is the same sphere as a million splats (4 s a load): one instant
    for t in (0.13,) if name == 'large' else (0.13, 0.71):
        img, hdr = splat(['instant', scene, '--time', t, '--res', RES], tmp_path / 's.exr')
        ref = truth_instant(scene, t, tmp_path / 'g.exr')
        assert ref[..., 3].any(), 'the instant shows something'
        assert np.abs(img - ref).max() <= ROUNDING, (name, t)
    assert hdr['refrender:method'] == 'instant'
    assert float(hdr['refrender:fragments']) > 0


def random_cloud(path, seed, n=150):
    """Random elliptical splats crossing each other in depth within a few
    epsilon, two objects (one turning, one translating), a moving camera."""
    rng = random.Random(seed)

    def vec(lo, hi):
        return ' '.join(f'{rng.uniform(lo, hi):.5f}' for _ in range(3))
    splats = []
    for _ in range(n):
        if rng.random() < 0.5:
            shape = f'normal="{vec(-1, 1)}" radius="{rng.uniform(0.05, 0.3):.4f}"'
        else:
            shape = f'u="{vec(-0.25, 0.25)}" v="{vec(-0.25, 0.25)}"'
        c = f'{rng.uniform(-1, 1):.4f} {rng.uniform(-0.8, 0.8):.4f} {rng.uniform(-0.05, 0.05):.4f}'
        splats.append(f'<splat center="{c}" {shape} color="{vec(0.1, 1)}"/>')
    half = n // 2
    path.write_text(f'''<scene>
  <camera position="0 0 4" lookat="0 0 0" up="0 1 0" fov="45" width="48" height="36">
    <animation><keyframes><key time="0" translate="0 0 0"/><key time="1" translate="0.2 0.1 0" rotate="0 3 0"/></keyframes></animation>
  </camera>
  <background color="0.1 0.2 0.3"/><ambient color="0.2 0.2 0.2"/>
  <light type="directional" direction="-0.3 -0.5 -1" color="0.9 0.9 0.85"/>
  <light type="point" position="1 2 3" color="0.3 0.3 0.3"/>
  <render epsilon="0.03" kernel_sigma="0.45"/>
  <object name="a"><pointModel>{"".join(splats[:half])}</pointModel>
    <material shading="phong" diffuse="0.9" specular="0.5" shininess="12"/>
    <animation><keyframes><key time="0" rotate="0 0 0"/><key time="1" rotate="10 40 5"/></keyframes></animation></object>
  <object name="b"><pointModel>{"".join(splats[half:])}</pointModel>
    <material shading="unlit"/>
    <animation><linear velocity="0.3 -0.2 0.4"/></animation></object>
</scene>''')


@pytest.mark.parametrize('seed', [1, 2, 3])
def test_instant_equals_the_ray_tracer_on_random_splat_clouds(tmp_path, seed):
    scene = tmp_path / 'cloud.xml'
    random_cloud(scene, seed)
    for t in (0.0, 0.37, 1.0):
        img, _ = splat(['instant', scene, '--time', t], tmp_path / 's.exr')
        ref = truth_instant(scene, t, tmp_path / 'g.exr', res='48x36')
        assert ref[..., 3].mean() > 0.2
        assert np.abs(img - ref).max() <= ROUNDING, (seed, t)


TINY_PAIR = '''<scene>
  <camera position="0 0 4" lookat="0 0 0" up="0 1 0" fov="45" width="48" height="36"/>
  <background color="0 0 0"/>
  <object name="front"><pointModel><splat center="0 0 0" normal="0 0 1" radius="0.0001" color="1 0 0"/></pointModel>
    <material shading="unlit"/></object>
  <object name="back"><pointModel><splat center="0 0 -2" normal="0 0 1" radius="0.0001" color="0 0 1"/></pointModel>
    <material shading="unlit"/></object>
</scene>'''


def test_botsch_filter_gives_a_subpixel_splat_its_2x2_pixels_and_blends_them(tmp_path):
    """Eq. 4.13 (sec. 4.2.3): a splat far below a pixel is accepted where
    d(x, y)^2 / r^2 <= 1 with r = sqrt 2 pixels from its projected centre.
    Projected onto the image centre (24, 18) of a 48x36 image, the four
    pixel centres about it lie at sqrt(1/2) pixel and the next ones at
    sqrt(5/2) or more: exactly the 2x2 block. These pixels write no depth
    (visibility pass: the ellipse only), so a second tiny splat far behind
    blends in with the same weight h(sqrt(1/4)): the mean of the colours."""
    scene = tmp_path / 'tiny.xml'
    scene.write_text(TINY_PAIR)
    none, _ = splat(['instant', scene, '--filter', 'none'], tmp_path / 'n.exr')
    assert not none[..., 3].any(), 'the reconstruction kernel alone misses every pixel centre'
    img, hdr = splat(['instant', scene, '--filter', 'botsch'], tmp_path / 'b.exr')
    covered = np.argwhere(img[..., 3] > 0)
    assert sorted(map(tuple, covered)) == [(17, 23), (17, 24), (18, 23), (18, 24)]
    for y, x in covered:
        assert np.allclose(img[y, x], [0.5, 0, 0.5, 1], atol=1e-6)
    assert 'filter=botsch' in hdr['refrender:methodParameters']


def test_ewa_filter_weighs_a_subpixel_splat_by_its_projected_area(tmp_path):
    """Ren, Pfister, Zwicker 2002, eq. 5/7: a splat far below a pixel becomes
    |J| G_I(x - m), the screen low-pass scaled by its projected area |J| (the
    reconstruction kernel's own variance is negligible at radius 1e-4). Cut
    at the kernel's 1 / sigma = 2 standard deviations, it covers the pixel
    centres within 2 pixels of (24, 18): the 12 at offsets (+-1/2, +-1/2),
    (+-3/2, +-1/2), (+-1/2, +-3/2). Two such splats at distances 4 and 6 on
    one line of sight blend with weights 1/4^2 : 1/6^2 = 36 : 16."""
    scene = tmp_path / 'tiny.xml'
    scene.write_text(TINY_PAIR)
    img, hdr = splat(['instant', scene, '--filter', 'ewa'], tmp_path / 'e.exr')
    covered = sorted(map(tuple, np.argwhere(img[..., 3] > 0)))
    want = sorted((18 + dy, 24 + dx) for dx in range(-2, 2) for dy in range(-2, 2)
                  if (dx + 0.5) ** 2 + (dy + 0.5) ** 2 <= 4)
    assert covered == want and len(want) == 12
    red = 36 / 52
    for y, x in covered:
        assert np.allclose(img[y, x], [red, 0, 1 - red, 1], atol=1e-4), img[y, x]
    assert 'filter=ewa' in hdr['refrender:methodParameters']


def nframe_average(scene, n, tmp_path, res=RES, shutter=(0.0, 1.0)):
    """scripts/nframe_average.py's midpoint procedure: the ray tracer's sharp
    instants at open + (k + 1/2) / N (close - open), averaged with equal
    weights (a box a(t))."""
    o, c = shutter
    frames = [truth_instant(scene, o + (k + 0.5) / n * (c - o), tmp_path / f'f{k}.exr', res) for k in range(n)]
    return np.mean(frames, axis=0)


@pytest.mark.parametrize('name', ['diagonal', 'crossing', 'camera_pan'])
def test_accum_midpoint_equals_the_n_frame_average(tmp_path, name):
    """Eq. 4.14 with box a(t) and the midpoint instants is the average of the
    N sharp instants (issue 51's second check)."""
    scene = ROOT / 'scenes' / f'{name}.xml'
    img, hdr = splat(['accum', scene, '--samples', 5, '--times', 'midpoint', '--res', RES], tmp_path / 'a.exr')
    avg = nframe_average(scene, 5, tmp_path)
    assert np.abs(img - avg).max() <= ROUNDING
    assert hdr['refrender:method'] == 'accum'
    assert 'samples=5 times=midpoint' in hdr['refrender:methodParameters']


def test_accum_weights_instants_by_a_t(tmp_path):
    """Eq. 4.14 weights each instant by a(t): with the table a(t) = 0.1 +
    1.8 t (scenes/README.md, weight="table": piecewise linear), the image is
    sum a(t_k) I_k / sum a(t_k) of the ray tracer's instants."""
    scene = tmp_path / 'w.xml'
    random_cloud(scene, 4)
    text = scene.read_text().replace('<background', '<shutter open="0" close="1" weight="table" '
                                     'table="0 0.1 1 1.9"/><background')
    scene.write_text(text)
    img, _ = splat(['accum', scene, '--samples', 4], tmp_path / 'a.exr')
    times = [(k + 0.5) / 4 for k in range(4)]
    w = [0.1 + 1.8 * t for t in times]
    frames = [truth_instant(scene, t, tmp_path / f'f{k}.exr', '48x36') for k, t in enumerate(times)]
    ref = sum(wk * f for wk, f in zip(w, frames)) / sum(w)
    assert np.abs(img - ref).max() <= ROUNDING


def test_bucket_with_one_instant_a_bucket_is_accumulation(tmp_path):
    """Sec. 4.4 with B = N: each bucket one instant, eq. 3.29's visibility
    exact at the instants: the accumulation buffer's image, bit for bit."""
    scene = ROOT / 'scenes' / 'crossing.xml'
    acc, _ = splat(['accum', scene, '--samples', 6, '--times', 'stratified', '--res', RES], tmp_path / 'a.exr')
    buck, hdr = splat(['bucket', scene, '--samples', 6, '--buckets', 6, '--times', 'stratified', '--res', RES],
                      tmp_path / 'b.exr')
    assert np.array_equal(acc, buck)
    assert 'buckets=6' in hdr['refrender:methodParameters']


def test_bucket_smears_opaque_and_less_with_more_buckets(tmp_path):
    """Sec. 3.6.2 / Fig. 3.7: instants sharing one z-buffer occlude one
    another, and a bucket is opaque wherever any of its instants covers the
    pixel, so a transparent blur turns opaque: the coverage (alpha) of B = 1
    exceeds the truth's, and the excess shrinks as B grows (B = N: none
    beyond the midpoint rule's error)."""
    scene = ROOT / 'scenes' / 'diagonal.xml'
    truth = nframe_average(scene, 12, tmp_path)[..., 3].mean()
    bias = []
    for b in (1, 3, 12):
        img, _ = splat(['bucket', scene, '--samples', 12, '--buckets', b, '--res', RES], tmp_path / f'b{b}.exr')
        bias.append(img[..., 3].mean() - truth)
    assert bias[0] > 0.5 * truth, bias  # the whole sweep opaque: far more than the bunny's share
    assert bias[0] > bias[1] > bias[2], bias
    assert abs(bias[2]) < 1e-6, bias


@pytest.mark.parametrize('args,message', [
    (['warp', 'S'], "unknown method 'warp'"),
    (['accum', 'S', '--buckets', 2], '--buckets is for bucket'),
    (['bucket', 'S', '--samples', 2, '--buckets', 3], '--buckets 3: at most --samples (2)'),
    (['instant', 'S', '--samples', 4], 'instant splats one instant'),
    (['accum', 'S', '--time', 0.5], '--time is the instant'),
    (['instant', 'S', '--filter', 'gauss'], "--filter: expected none, botsch or ewa, got 'gauss'"),
    (['accum', 'S', '--times', 'halton'], "--times: expected midpoint, stratified or random"),
    (['volumetric', 'S', '--filter', 'botsch'], 'no --buckets or --filter'),
    (['instant', 'S', '--alpha', 'thesis'], '--alpha and --sigma-t are for volumetric'),
    (['instant'], 'expected a method and a scene file'),
    (['instant', 'S', '--samplez', 3], "did you mean '--samples'"),
])
def test_usage_errors_exit_2_and_write_nothing(tmp_path, args, message):
    out = tmp_path / 'o.exr'
    proc = run(['splat', *[str(ROOT / 'scenes' / 'diagonal.xml') if a == 'S' else a for a in args], '-o', out])
    assert proc.returncode == 2, proc.stderr
    assert message in proc.stderr
    assert not out.exists()


def test_help_names_every_method(tmp_path):
    proc = run(['splat', '--help'])
    assert proc.returncode == 0
    for word in ('instant', 'accum', 'bucket', 'volumetric', 'guan-mueller', '--filter', '--alpha', '--sigma-t', '--trails',
                 'src/SPLAT.md'):
        assert word in proc.stdout


def test_bad_scenes_name_file_and_line_and_leave_the_output(tmp_path):
    out = tmp_path / 'o.exr'
    out.write_bytes(b'keep')
    bad = tmp_path / 'bad.xml'
    bad.write_text('<scene>\n<camera width="8" height="8"/>\n<object><pointModel><splat center="0 0"/></pointModel></object>\n</scene>')
    proc = run(['splat', 'instant', bad, '-o', out])
    assert proc.returncode == 1 and f'{bad}:3' in proc.stderr, proc.stderr
    sphere = tmp_path / 'sphere.xml'
    sphere.write_text('<scene><camera width="8" height="8"/><object name="ball"><sphere radius="1"/></object></scene>')
    proc = run(['splat', 'accum', sphere, '-o', out])
    assert proc.returncode == 1 and "object 'ball' is an analytic sphere" in proc.stderr, proc.stderr
    proc = run(['splat', 'volumetric', ROOT / 'scenes' / 'gaussians.xml', '-o', out])  # as README says
    assert proc.returncode == 1 and 'is a Gaussian-splat model' in proc.stderr and 'point models (surfels) only' in proc.stderr, \
        proc.stderr
    proc = run(['splat', 'instant', sphere, '-o', tmp_path / 'o.png'])
    assert proc.returncode == 1 and 'OpenEXR' in proc.stderr
    assert out.read_bytes() == b'keep'
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith('.') or 'tmp' in p.name] == []


@pytest.mark.parametrize('method', [['instant'], ['accum', '--samples', 2], ['bucket', '--samples', 2, '--buckets', 1],
                                    ['volumetric', '--samples', 2], ['guan-mueller']])
def test_every_method_renders_every_suite_scene(tmp_path, method):
    """Issue 51: refrender splat renders every suite scene with each method,
    camera_pan's moving camera included (volumetric kernels along the
    motion relative to the camera, src/SPLAT.md). large, a million splats
    of a spinning sphere (rotation's motion; 2 s a load), with one method:
    the instant, which test_instant_equals_the_ray_tracer_at_pixel_centres
    also checks on it."""
    for name in SUITE if method[0] == 'instant' else [n for n in SUITE if n != 'large']:
        img, hdr = splat([method[0], ROOT / 'scenes' / f'{name}.xml', *method[1:], '--res', '16x12'],
                         tmp_path / 's.exr')
        assert np.isfinite(img).all() and img[..., 3].max() > 0, name
        assert img[..., 3].min() >= 0 and img[..., 3].max() <= 1, name
        assert hdr['refrender:method'] == method[0]


@pytest.mark.parametrize('velocity', ['1 0 0', '0 0 0'])
def test_splat_refuses_the_instants_and_shutters_the_ray_tracer_refuses(tmp_path, velocity):
    """Issue 56: splat --time accepted 1e300, where the ray tracer refuses any
    instant or shutter that moves an object past RR_MAX_REACH (1e15). Both
    now apply one rule (accel_check_reach): for each instant and shutter the
    two commands accept or refuse alike, and a refusal names the object."""
    scene = tmp_path / 's.xml'
    scene.write_text('<scene><camera position="0 0 4" lookat="0 0 0" width="8" height="6"/>'
                     '<object name="dot"><pointModel><splat center="0 0 0" normal="0 0 1" radius="0.5"/></pointModel>'
                     f'<animation><linear velocity="{velocity}"/></animation></object></scene>')
    cases = [(['--time', t], ['instant', '--time', t]) for t in ('1e300', '-1e16', '1e16', '1e14', '0.5')]
    cases += [(['--shutter', s], [m, '--shutter', s, '--samples', 1]) for s in ('0,1e300', '0,1e14')
              for m in ('accum', 'volumetric')]
    refused = 0
    for render_args, splat_args in cases:
        truth = run([scene, *render_args, '--spp', 1, '--tspp', 1, '-o', tmp_path / 'r.exr', '--quiet'])
        mine = run(['splat', splat_args[0], scene, *splat_args[1:], '-o', tmp_path / 's.exr', '--quiet'])
        assert (mine.returncode == 0) == (truth.returncode == 0), (splat_args, truth.stderr, mine.stderr)
        if mine.returncode:
            assert mine.returncode == 1 and "object 'dot' reaches" in mine.stderr, mine.stderr
            refused += 1
    assert refused == (5 if velocity != '0 0 0' else 0), refused
