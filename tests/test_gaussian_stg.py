"""A SpacetimeGaussians "lite" model (its Gaussians move; the layout of
oppo-us-research/SpacetimeGaussians 427abfc5 scene/ourslite.py save_ply,
lines 335-387) is refused with its file named until the renderer evaluates
it at each time: rendered as a static 3DGS model it would be wrong without
a word. Its evaluation and bounds: tests/test_gaussian_dynamic.c."""
import numpy as np

import gsply
from conftest import run

NAMES = (["x", "y", "z", "trbf_center", "trbf_scale", "nx", "ny", "nz"] + [f"motion_{i}" for i in range(9)] +
         ["f_dc_0", "f_dc_1", "f_dc_2", "opacity", "scale_0", "scale_1", "scale_2"] +
         [f"rot_{i}" for i in range(4)] + [f"omega_{i}" for i in range(4)])


def write_stg_lite(path, n=4):
    """n Gaussians in front of the camera, moving along x, as float32 binary little endian."""
    v = np.zeros((n, len(NAMES)))
    col = {p: i for i, p in enumerate(NAMES)}
    v[:, col["x"]] = np.linspace(-0.5, 0.5, n)
    v[:, col["motion_0"]] = 1.0
    v[:, col["f_dc_0"]] = 0.8
    v[:, [col["scale_0"], col["scale_1"], col["scale_2"]]] = np.log(0.1)
    v[:, col["rot_0"]] = 1.0
    head = "ply\nformat binary_little_endian 1.0\nelement vertex %d\n" % n
    head += "".join(f"property float {p}\n" for p in NAMES) + "end_header\n"
    path.write_bytes(head.encode() + v.astype("<f4").tobytes())


def test_an_stg_lite_model_is_refused_naming_its_file(tmp_path):
    ply = tmp_path / "stg_lite.ply"
    write_stg_lite(ply)
    scene = tmp_path / "s.xml"
    scene.write_text(f'<scene>{gsply.camera_xml(np.eye(3), np.zeros(3), 100.0, 16, 16)}'
                     f'<object name="g" position="0 0 4"><gaussianModel file="{ply}"/></object></scene>')
    out = tmp_path / "x.exr"
    proc = run([scene, "--spp", 1, "-o", out, "--quiet"])
    assert proc.returncode == 1, proc.stderr
    assert str(ply) in proc.stderr and "dynamic models are not rendered yet" in proc.stderr, proc.stderr
    assert not out.exists()
