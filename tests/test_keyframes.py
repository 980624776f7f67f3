"""Keyframed animation (keys and Maya .anim files), camera motion and frame
sequences, end to end."""
import numpy as np

from conftest import ROOT, coverage_centroid, focal_pixels, read_exr, read_full, run
from test_coverage import SCENE, chord_integral

W, H, FOV, D = 160, 40, 30.0, 10.0
F = focal_pixels(H, FOV) / D            # pixels per world unit at depth D
RHO_PX, PATH_PX = 12.0, 64.0
R, V = RHO_PX / F, PATH_PX / F


def disk_scene(animation="", camera=""):
    """The moving-disk scene of test_coverage: a white unlit disk at depth D,
    starting half a path left of the axis."""
    geometry = (f'<pointModel><splat center="{-V / 2} 0 -{D}" normal="0 0 1" radius="{R}" '
                f'color="1 1 1"/></pointModel>')
    xml = SCENE.format(geometry=geometry, w=W, h=H, fov=FOV, weight="", animation=animation)
    return xml.replace('height="40"/>', f'height="40">{camera}</camera>') if camera else xml


def check_chord_profile(alpha):
    """Per-row coverage of a disk moving PATH_PX pixels right over the
    shutter equals the chord integral over the path length (see
    test_coverage.test_linearly_moving_disk_matches_chord_over_speed)."""
    x_lo, x_hi = W / 2 - PATH_PX / 2 + RHO_PX, W / 2 + PATH_PX / 2 - RHO_PX
    cols = np.arange(int(np.ceil(x_lo)), int(np.floor(x_hi)))
    for j in range(H):
        expected = chord_integral(j - H / 2, j + 1 - H / 2, RHO_PX) / PATH_PX
        row = alpha[j, cols]
        se = row.std(ddof=1) / np.sqrt(len(row))
        assert abs(row.mean() - expected) <= 5 * se + 1e-4, (j, row.mean(), expected, se)


ARGS = ["--spp", 4, "--tspp", 16, "--seed", 7]


def test_keyed_linear_path_equals_linear_animation_bit_for_bit(render):
    linear = render(disk_scene(f'<animation><linear velocity="{V} 0 0"/></animation>'), *ARGS)
    keyed = render(disk_scene('<animation><keyframes interpolation="linear">'
                              '<key time="0" translate="0 0 0"/>'
                              f'<key time="1" translate="{V} 0 0"/></keyframes></animation>'), *ARGS)
    assert np.array_equal(linear, keyed)
    check_chord_profile(keyed[:, :, 3])


def test_camera_motion_blurs_a_static_disk_by_the_chord_integral(render):
    """Thesis eq. 3.6: a camera moving left by V sees the static disk move
    right by PATH_PX pixels; the blur must match the closed form."""
    camera = ('<animation><keyframes interpolation="linear"><key time="0" translate="0 0 0"/>'
              f'<key time="1" translate="{-V} 0 0"/></keyframes></animation>')
    img = render(disk_scene(camera=camera), *ARGS)
    check_chord_profile(img[:, :, 3])


LIT = """<scene>
 <camera position="0 0.5 6" lookat="0 0 0" up="0 1 0" fov="40" width="64" height="48">{camera}</camera>
 <shutter open="0" close="1"/>
 <light type="directional" direction="-0.3 -0.6 -1" color="1 1 1"/>
 <ambient color="0.1 0.1 0.1"/>
 <render epsilon="0.02"/>
 <object position="0 0 -1"><pointModel generate="plane" count="4000" radius="3" checker="4"
   color="0.9 0.9 0.9" color2="0.2 0.3 0.5"/>{move}</object>
 <object><sphere radius="0.8" color="0.9 0.5 0.2"/>
   <material shading="phong" specular="0.5" shininess="20"/>{move}</object>
</scene>"""


def test_translating_camera_equals_the_scene_translating_the_other_way(render):
    """Only relative motion matters (directional light, specular from the
    eye): same seed, so the same relative rays up to rounding."""
    cam = ('<animation><keyframes interpolation="linear"><key time="0" translate="0 0 0"/>'
           '<key time="1" translate="0.6 0.2 0"/></keyframes></animation>')
    move = '<animation><linear velocity="-0.6 -0.2 0"/></animation>'
    a = render(LIT.format(camera=cam, move=""), "--spp", 4, "--tspp", 24)
    b = render(LIT.format(camera="", move=move), "--spp", 4, "--tspp", 24)
    diff = np.abs(a - b)
    assert diff.mean() < 1e-4, diff.mean()
    assert np.mean(diff.max(axis=2) > 0.01) < 0.01
    static = render(LIT.format(camera="", move=""), "--spp", 4, "--tspp", 24)
    assert np.abs(a - static).mean() > 100 * diff.mean()  # and the motion does show


def pinwheel(n_rings=10, n_spokes=48, radius=1.0):
    """A disk of splats, red for polar angle in [0, pi), green otherwise."""
    splats = []
    for i in range(n_rings):
        r = (i + 0.5) / n_rings * radius
        count = max(6, int(n_spokes * (i + 0.5) / n_rings))
        for k in range(count):
            a = 2 * np.pi * (k + 0.5) / count
            color = "1 0 0" if a < np.pi else "0 1 0"
            splats.append(f'<splat center="{r * np.cos(a)} {r * np.sin(a)} 0" normal="0 0 1" '
                          f'radius="{1.6 * radius / n_rings}" color="{color}"/>')
    return "".join(splats)


def test_disk_spinning_a_full_turn_about_its_normal_is_rotationally_symmetric(render):
    """Over a full turn with a box shutter, the time a point is covered and
    red depends only on its distance from the axis: the image equals itself
    turned by 90 degrees, and inside, red and green each take half."""
    n, tspp = 64, 64
    xml = f"""<scene>
 <camera position="0 0 0" lookat="0 0 -1" up="0 1 0" fov="30" width="{n}" height="{n}"/>
 <shutter open="0" close="1"/>
 <render epsilon="0.01"/>
 <object position="0 0 -5"><pointModel>{pinwheel()}</pointModel><material shading="unlit"/>
  <animation><keyframes interpolation="linear"><key time="0" rotate="0 0 0"/>
   <key time="1" rotate="0 0 360"/></keyframes></animation></object>
</scene>"""
    img = render(xml, "--spp", 4, "--tspp", tspp, "--batches", 4)
    rgba = img[:, :, :4]
    # a point's samples: 4 batches x tspp stratified times, so each pixel
    # value has standard error below 0.5 / sqrt(4 tspp) (spatial spread too)
    se = 0.5 / np.sqrt(4 * tspp)
    turned = np.rot90(rgba, 1, axes=(0, 1))
    assert np.abs(rgba - turned).max() < 2 * 5 * se
    f = focal_pixels(n, 30) / 5
    y, x = np.mgrid[0:n, 0:n] + 0.5
    inside = np.hypot(x - n / 2, y - n / 2) < 0.8 * f
    assert inside.sum() > 100
    assert np.all(np.abs(rgba[inside, 0] - 0.5) < 5 * se)
    assert np.all(np.abs(rgba[inside, 1] - 0.5) < 5 * se)
    # without motion the pinwheel is anything but symmetric
    still = render(xml.replace('rotate="0 0 360"', 'rotate="0 0 0"'), "--spp", 4, "--tspp", 4)
    assert np.abs(still[:, :, 0] - np.rot90(still[:, :, 0])).max() > 0.5


ANIMATED = ROOT / "scenes" / "animated.xml"
SMALL = ["--res", "96x54", "--spp", 1, "--tspp", 8, "--quiet"]


def test_frame_sequence_renders_each_frame_as_alone(tmp_path):
    """--frames shares models and BVHs across frames; every frame must equal
    the same frame rendered on its own, with its own shutter."""
    proc = run([ANIMATED, *SMALL, "--frames", "3-5", "-o", tmp_path / "seq.%04d.exr"])
    assert proc.returncode == 0, proc.stderr
    assert sorted(p.name for p in tmp_path.glob("seq.*.exr")) == ["seq.0003.exr", "seq.0004.exr", "seq.0005.exr"]
    alone = tmp_path / "alone.exr"
    assert run([ANIMATED, *SMALL, "--frame", 4, "-o", alone]).returncode == 0
    seq4, header = read_exr(tmp_path / "seq.0004.exr")
    assert np.array_equal(seq4, read_exr(alone)[0])
    opened, closed = map(float, header["refrender:shutter"].split())
    assert abs(opened - 4 / 24) < 1e-12 and abs(closed - 4.5 / 24) < 1e-12
    assert not np.array_equal(seq4, read_exr(tmp_path / "seq.0003.exr")[0])


def test_frame_options_are_checked(tmp_path):
    bad = run([ANIMATED, "--frames", "0-2", "-o", tmp_path / "out.exr"])
    assert bad.returncode == 2 and "%04d" in bad.stderr
    assert run([ANIMATED, "--frames", "5-2"]).returncode == 2
    assert run([ANIMATED, "--frames", "0-1", "--checkpoint", tmp_path / "c.exr", "-o", "o.%d.exr"]).returncode == 2
    no_rate = ROOT / "scenes" / "default.xml"
    proc = run([no_rate, "--frame", 2, "-o", tmp_path / "x.exr", *SMALL])
    assert proc.returncode == 1 and "default.xml" in proc.stderr and "frame rate" in proc.stderr
    assert not (tmp_path / "x.exr").exists()


def test_bad_anim_file_is_reported_with_its_line(tmp_path):
    (tmp_path / "bad.anim").write_text("animVersion 1.1;\nanim translateX translateX n 0 0 0;\n"
                                       "animData {\n input time;\n keys {\n  0 0 linear wobbly 1 1 0;\n }\n}\n")
    scene = tmp_path / "s.xml"
    scene.write_text('<scene>\n<object><sphere radius="1"/>\n<animation>bad.anim</animation></object></scene>')
    proc = run([scene, "-o", tmp_path / "o.exr", "--quiet"])
    assert proc.returncode == 1
    assert "bad.anim:6: unknown or unsupported tangent type 'wobbly'" in proc.stderr
    assert "s.xml:3" in proc.stderr
    assert not (tmp_path / "o.exr").exists()


def test_animated_scene_renders_frame_0_without_frame_options(tmp_path):
    """scenes/animated.xml's header: without the frame-range option frame 0
    is rendered (its shutter: 24 fps, 180 degrees), the same as --frame 0."""
    plain, alone = tmp_path / "plain.exr", tmp_path / "f0.exr"
    assert run([ANIMATED, *SMALL, "-o", plain]).returncode == 0
    assert run([ANIMATED, *SMALL, "--frame", 0, "-o", alone]).returncode == 0
    a, ha = read_exr(plain)
    b, hb = read_exr(alone)
    assert np.array_equal(a, b)
    opened, closed = map(float, ha["refrender:shutter"].split())
    assert opened == 0 and abs(closed - 0.5 / 24) < 1e-12
    text = ANIMATED.read_text()
    assert "0-23" in text and "without it frame 0 is rendered" in text


RIG = ROOT / "scenes" / "animations" / "rig.anim"


def rig_hand_position(frame):
    """scenes/animations/rig.anim's node 'hand', evaluated from Maya's curve
    definitions, in meters; nothing of refrender's curve code.
    translateX: a weighted Bezier, time controls 0, 16, 16, 24 frames (the
    fixed flat tangent's weight 16, the auto end key's handle a third of the
    interval) and values 0, 0, 100, 100 cm: x(u) = 24 (2u - 2u^2 + u^3),
    solved for u. translateY: spline 0, 30, 0 cm at frames 0, 12, 24 with
    slopes 2.5, 0, -2.5 cm/frame and handles of 4 frames (evenly spaced in
    time, so the parameter is linear in time). translateZ: step."""
    u = [r.real for r in np.roots([1, -2, 2, -frame / 24]) if abs(r.imag) < 1e-12 and -1e-12 <= r.real <= 1 + 1e-12]
    assert len(u) == 1
    x = 100 * (3 * u[0] ** 2 * (1 - u[0]) + u[0] ** 3)
    seg, s = (0, frame / 12) if frame < 12 else (1, (frame - 12) / 12)
    ys = [0, 10, 30, 30] if seg == 0 else [30, 30, 10, 0]
    y = sum(c * b for c, b in zip(ys, [(1 - s) ** 3, 3 * s * (1 - s) ** 2, 3 * s * s * (1 - s), s ** 3]))
    z = 0 if frame < 12 else -50
    return np.array([x, y, z]) / 100


def test_rig_hand_evaluates_in_closed_form():
    """The worked values in rig.anim's comment: 50 cm at frame 15 (u = 1/2);
    y 18.75 cm at frame 6 and 26.71875 cm at frame 15."""
    assert np.allclose(rig_hand_position(15), [0.5, 0.2671875, -0.5], atol=1e-12)
    assert abs(rig_hand_position(6)[1] - 0.1875) < 1e-12


def test_maya_multi_node_weighted_file_renders_the_chosen_node_where_maya_puts_it(tmp_path):
    """Maya .anim files end to end: a multi-node file with weighted, fixed, auto,
    spline and step keys renders node 'hand' at its hand-evaluated position.
    A small unlit disc at the node's pivot, an instantaneous shutter at
    frames 6 and 15: the centroid of its coverage is the pinhole projection
    of rig_hand_position within 0.1 pixel (the other node's curves, or the
    weighted curve read as Hermite, put it pixels away)."""
    (tmp_path / "rig.anim").write_text(RIG.read_text())
    w, h, fov, dist = 96, 64, 30.0, 10.0
    scene = tmp_path / "rig.xml"
    scene.write_text(f'<scene><camera position="0 0 {dist}" lookat="0 0 0" up="0 1 0" fov="{fov}" width="{w}" '
                     f'height="{h}"/><object><pointModel><splat center="0 0 0" normal="0 0 1" radius="0.05"/>'
                     '</pointModel><material shading="unlit"/><animation file="rig.anim" node="hand"/></object>'
                     '</scene>')
    f = focal_pixels(h, fov)
    for frame in (6, 15):
        t = frame / 24
        out = tmp_path / f"f{frame}.exr"
        proc = run([scene, "-o", out, "--shutter", f"{t},{t + 1e-7}", "--sampler", "sobol", "--spp", 64,
                    "--tspp", 1, "--quiet"])
        assert proc.returncode == 0, proc.stderr
        x, y, z = rig_hand_position(frame)
        px, py = w / 2 + f * x / (dist - z), h / 2 - f * y / (dist - z)
        cx, cy = coverage_centroid(read_full(out)[0]["A"])
        assert abs(px - cx) < 0.1 and abs(py - cy) < 0.1, (frame, px, py, cx, cy)


def test_a_scale_extrapolated_through_zero_is_warned_about(tmp_path):
    """A keyframed scale extrapolated below zero is held
    at 1e-9 and the object silently vanished; now a warning names it. A
    scale that stays positive gives none."""
    def scene(s1):
        return f"""<scene><camera position="0 0 5" lookat="0 0 0" width="4" height="4"/>
<shutter open="0" close="2"/><object name="shrinker"><sphere radius="0.5"/><animation>
<keyframes post="linear"><key time="0" scale="1 1 1"/><key time="1" scale="{s1} {s1} {s1}"/></keyframes>
</animation></object></scene>"""
    for s1, warned in [("0.2", True), ("0.8", False)]:  # at t = 2: -0.6 and 0.6
        path = tmp_path / f"k{s1}.xml"
        path.write_text(scene(s1))
        proc = run([path, "--spp", 1, "--tspp", 2, "-o", tmp_path / "k.exr"])
        assert proc.returncode == 0, proc.stderr
        assert ("object 'shrinker': its keyframed scale reaches zero" in proc.stderr) == warned, proc.stderr
