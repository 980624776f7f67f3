"""EXR header: numbers are stored as EXR numbers, the rest-pose
camera as OpenEXR m44f worldToCamera / worldToNDC (row vectors, Imath's
convention), and a frame render names its frame and shutter. The matrices
are checked by projecting a small disc's center and finding it where the
render puts it (the centroid of its coverage), to a tenth of a pixel."""
import numpy as np

from conftest import coverage_centroid, read_full, run

DISC = """<scene><camera position="0.3 0.2 4" lookat="0 0 0" up="0.1 1 0" fov="40" width="{w}" height="{h}"/>
<frames rate="24"/>
<object position="{x} {y} {z}"><pointModel><splat center="0 0 0" normal="{nx} {ny} {nz}" radius="0.06"/>
</pointModel><material shading="unlit"/></object></scene>"""


def matrix(header, key):
    m = np.asarray(header[key], dtype=np.float64)
    assert m.shape == (16,), (key, header[key])
    return m.reshape(4, 4)


def test_numbers_are_numbers_and_frames_name_themselves(tmp_path):
    scene = tmp_path / "s.xml"
    scene.write_text(DISC.format(w=16, h=12, x=0, y=0, z=0, nx=0, ny=0, nz=1))
    out = tmp_path / "f.exr"
    assert run([scene, "-o", out, "--frame", 3, "--spp", 1, "--tspp", 2, "--quiet"]).returncode == 0
    _, h = read_full(out)
    assert h["refrender:spp"] == 1 and h["refrender:tspp"] == 2 and h["refrender:batches"] == 1
    assert isinstance(h["refrender:epsilon"], float) and h["refrender:frame"] == 3
    # the default shutter [0, 1] shifted by frame / rate
    assert h["refrender:shutterOpen"] == 3 / 24 and h["refrender:shutterClose"] == 1 + 3 / 24
    assert h["refrender:frameRate"] == 24.0


def test_world_to_ndc_projects_onto_the_rendered_position(tmp_path):
    width, height = 96, 64
    for k, (x, y, z) in enumerate([(0.8, 0.5, 0.3), (-1.1, -0.4, -0.5), (0.0, 0.9, 1.0)]):
        scene = tmp_path / f"d{k}.xml"
        to_eye = np.array([0.3, 0.2, 4.0]) - np.array([x, y, z])
        n = to_eye / np.linalg.norm(to_eye)  # face the camera: a round image
        scene.write_text(DISC.format(w=width, h=height, x=x, y=y, z=z, nx=n[0], ny=n[1], nz=n[2]))
        out = tmp_path / f"d{k}.exr"
        assert run([scene, "-o", out, "--sampler", "sobol", "--spp", 64, "--tspp", 1, "--quiet"]).returncode == 0
        ch, h = read_full(out)
        ndc = np.array([x, y, z, 1.0]) @ matrix(h, "worldToNDC")
        px, py = ndc[0] / ndc[3] * width, ndc[1] / ndc[3] * height
        cx, cy = coverage_centroid(ch["A"])
        assert abs(px - cx) < 0.1 and abs(py - cy) < 0.1, (px, py, cx, cy)
        cam = np.array([x, y, z, 1.0]) @ matrix(h, "worldToCamera")
        forward = -np.array([0.3, 0.2, 4.0]) / np.linalg.norm([0.3, 0.2, 4.0])
        assert np.isclose(cam[2], np.dot(np.array([x, y, z]) -
                          np.array([0.3, 0.2, 4.0]), forward), rtol=1e-5)  # z: depth along the view
        assert np.isclose(1.0 / (ndc[2] / ndc[3]), cam[2], rtol=1e-5)  # z: 1 / depth


def test_camera_matrices_beyond_float32_are_refused(tmp_path):
    """worldToCamera and worldToNDC are float32 in the header: a camera whose matrices hold a
    number past float's range (3.4e38) would be written as infinity. The intrinsics' own rules
    do not catch a tiny fov (its 1 / tan is 5.7e301) or a far position (the translation itself),
    so the header's check must: refused, naming the file and line, with no output written."""
    for camera in ('position="0 0.2 4" lookat="0 0 0" fov="1e-300"',
                   'position="0 0 4e38" lookat="0 0 0" fov="40"'):
        scene = tmp_path / "s.xml"
        scene.write_text(f'<scene>\n<camera {camera} width="8" height="8"/>\n'
                         '<object><sphere radius="1"/></object></scene>')
        out = tmp_path / "f.exr"
        proc = run([scene, "-o", out, "--spp", 1, "--tspp", 1, "--quiet"])
        assert proc.returncode != 0 and f"{scene}:2:" in proc.stderr and "float32" in proc.stderr, \
            (camera, proc.returncode, proc.stderr)
        assert not out.exists()
    # a scene whose camera fits at its own size, pushed past float by --res: named with both
    scene.write_text('<scene>\n<camera position="0 0 4" lookat="0 0 0" fov="1e-34" width="8" height="8"/>\n'
                     '<object><sphere radius="1"/></object></scene>')
    proc = run([scene, "-o", out, "--res", "1x1000", "--spp", 1, "--tspp", 1, "--quiet"])
    assert proc.returncode != 0 and f"{scene} with --res 1x1000:" in proc.stderr and "float32" in proc.stderr, \
        proc.stderr
    assert not out.exists()
