"""scripts/gallery.py, the contact sheet `make references` and `make gallery`
write: a tile shows the image's RGB as stored, so a refrender render's own
background (its RGB holds background x (1 - coverage)) appears, not black;
the committed reference_images/gallery.png is what gallery.py makes of the
committed references in the Makefile's suite order; a sheet without labels
is announced on stderr."""
import re
import subprocess

import numpy as np
import OpenImageIO as oiio

from conftest import ROOT, run

GALLERY = ROOT / "scripts" / "gallery.py"
LABEL = 18  # gallery.py's label band, in pixels


def gallery(*args):
    return subprocess.run(["/usr/bin/python3", str(GALLERY), *map(str, args)], capture_output=True, text=True,
                          timeout=120)


def read8(path):
    return oiio.ImageBuf(str(path)).get_pixels(oiio.UINT8).astype(int)


def srgb8(linear):
    """8-bit sRGB code of a linear value (IEC 61966-2-1)."""
    v = np.where(linear <= 0.0031308, 12.92 * linear, 1.055 * np.power(linear, 1 / 2.4) - 0.055)
    return np.round(v * 255).astype(int)


def test_a_tile_shows_the_scenes_own_background(tmp_path):
    background = np.array([0.2, 0.3, 0.4])
    scene = tmp_path / "s.xml"
    scene.write_text('<scene><camera width="16" height="12"/><background color="0.2 0.3 0.4"/>'
                     '<object><sphere radius="1"/></object></scene>')
    assert run([scene, "-o", tmp_path / "s.exr", "--spp", 1, "--tspp", 1, "--quiet"]).returncode == 0
    empty = oiio.ImageBuf(str(tmp_path / "s.exr")).get_pixels(oiio.FLOAT)[..., 3] == 0  # alpha: nothing covered
    assert empty.any()
    proc = gallery(tmp_path / "g.png", tmp_path / "s.exr")
    assert proc.returncode == 0, proc.stderr
    sheet = read8(tmp_path / "g.png")
    tile = sheet[sheet.shape[0] - 12:]  # below the label band, when there is one
    assert np.abs(tile[empty] - srgb8(background)).max() <= 1


def suite():
    """The Makefile's SUITE, in order: the scenes of the committed gallery."""
    text = (ROOT / "Makefile").read_text()
    (body,) = re.findall(r"^SUITE\s*:=((?:.*\\\n)*.*)$", text, re.M)
    return body.replace("\\\n", " ").split()


def test_the_committed_gallery_is_what_gallery_py_makes_of_the_references(tmp_path):
    refs = [ROOT / "reference_images" / f"{name}.exr" for name in suite()]
    proc = gallery(tmp_path / "g.png", *refs)
    assert proc.returncode == 0 and proc.stderr == "", proc.stderr
    made, committed = read8(tmp_path / "g.png"), read8(ROOT / "reference_images" / "gallery.png")
    assert made.shape == committed.shape
    # the images exactly; the labels' glyphs (rasterised by the machine's FreeType) only where they are
    tile_h = made.shape[0] // ((len(refs) + 3) // 4)
    band = (np.arange(made.shape[0]) % tile_h) < LABEL
    assert np.array_equal(made[~band], committed[~band])
    assert made[band].max() > 128 and committed[band].max() > 128  # light text on the dark band


def test_a_sheet_without_labels_says_so(tmp_path):
    image = ROOT / "reference_images" / "diagonal.exr"
    proc = gallery(tmp_path / "g.png", image, "--font", tmp_path / "no-such-font.ttf")
    assert proc.returncode == 0
    assert "no labels" in proc.stderr and "no-such-font.ttf" in proc.stderr
    assert read8(tmp_path / "g.png").shape[:2] == (192, 256)  # the image alone, no label band
