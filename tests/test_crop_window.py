"""--crop-window: only the window's pixels are rendered, into a
full-size EXR whose data window is that region (pbrt's rounding); every
sample is a pure function of (seed, pixel, batch), so the window's pixels
equal the same pixels of the whole image bit for bit."""
import numpy as np
import OpenImageIO as oiio

from conftest import run

SCENE = """<scene><camera position="0 0 4" lookat="0 0 0" width="40" height="30"/>
<object><pointModel generate="sphere" count="2000" radius="1" checker="4"/>
<animation><linear velocity="0.5 0 0"/></animation></object></scene>"""


def read(path):
    inp = oiio.ImageInput.open(str(path))
    spec = inp.spec()
    px = inp.read_image(oiio.FLOAT)
    inp.close()
    return spec, px


def test_crop_window_equals_the_whole_image_there(tmp_path):
    scene = tmp_path / "s.xml"
    scene.write_text(SCENE)
    args = ["--spp", 1, "--tspp", 8, "--batches", 2, "--quiet"]
    assert run([scene, "-o", tmp_path / "full.exr", *args]).returncode == 0
    assert run([scene, "-o", tmp_path / "crop.exr", "--crop-window", "0.25,0.75,0.1,0.5", *args]).returncode == 0
    full_spec, full = read(tmp_path / "full.exr")
    spec, crop = read(tmp_path / "crop.exr")
    # pixels [ceil(0.25 * 40), ceil(0.75 * 40)) x [ceil(0.1 * 30), ceil(0.5 * 30)) = [10, 30) x [3, 15)
    assert (spec.x, spec.y, spec.width, spec.height) == (10, 3, 20, 12)
    assert (spec.full_width, spec.full_height) == (40, 30)
    assert list(spec.channelnames) == list(full_spec.channelnames)
    assert np.array_equal(crop, full[3:15, 10:30])
    assert spec.get_string_attribute("refrender:cropWindow").split()[:2] == ["0.25", "0.75"]


def test_crop_window_mistakes_are_refused(tmp_path):
    scene = tmp_path / "s.xml"
    scene.write_text(SCENE)
    empty = run([scene, "-o", tmp_path / "x.exr", "--crop-window", "0.501,0.52,0,1"])
    assert empty.returncode == 1 and "no whole pixel" in empty.stderr
    bad = run([scene, "-o", tmp_path / "x.exr", "--crop-window", "0.6,0.5,0,1"])
    assert bad.returncode == 2 and "X0 < X1" in bad.stderr
    both = run([scene, "-o", tmp_path / "x.exr", "--crop-window", "0,1,0,1", "--batches", 2, "--pass", "0/2"])
    assert both.returncode == 2 and "--crop-window" in both.stderr
