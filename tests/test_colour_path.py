"""The colour model and the channels along the user's whole path (issue 55,
items 1 and 2): render, preview, compare.py, nframe_average.py, gallery.py
and cost_error.py, against files written as other tools write them.

Expectations come from outside refrender's C: the Gaussian rasterizers write
a frame as clamp(colour) * 255 rounded half up (gaussian-splatting 1152adc
render.py:34 through torchvision's save_image, mul(255).add_(0.5).clamp_(0,
255)), applied here to tests/gs2d_reference.py's numpy forward pass; a model's
colours are sRGB-encoded display values (fitted to 8-bit photographs), so an
image of them must say sRGB and its preview must be those values, while a
--blur-space linear render holds linear light. Blender names its channels
Combined.R (or ViewLayer.Combined.R); a file without one of R, G, B has no
colour image, and nothing may stand in for it."""
import contextlib
import io
import json
import os
import subprocess
import sys

import numpy as np
import OpenImageIO as oiio

import gs2d_reference as ref
import gsply
import compare as compare_script  # scripts/, put on the path by conftest
import imagecompare
from conftest import BIN, ROOT, run
from gsply import rotation

NFRAME = ROOT / "scripts" / "nframe_average.py"
W, H, F = 32, 24, 30.0
BACKGROUND = (1.0, 1.0, 1.0)  # white, as the deblurring scenes: clamping at 1 matters


def model(seed=5, n=30):
    """Overlapping SH-degree-0 splats whose colours span [-0.2, 1.2]: some clamp at 0 and 1, most
    lie where the sRGB curve moves a value by many levels."""
    rng = np.random.default_rng(seed)
    q = rng.normal(size=(n, 4))
    colour = rng.uniform(-0.2, 1.2, (n, 3))
    return {"mean": rng.uniform(-0.6, 0.6, (n, 3)), "scale": rng.uniform(0.1, 0.3, (n, 2)),
            "rot": q / np.linalg.norm(q, axis=1)[:, None], "opacity": rng.uniform(0.5, 0.9, n),
            "sh": ((colour - 0.5) / 0.28209479177387814).reshape(n, 1, 3), "degree": 0}


def write_png(path, rgb8):
    out = oiio.ImageOutput.create(str(path))
    assert out.open(str(path), oiio.ImageSpec(rgb8.shape[1], rgb8.shape[0], 3, oiio.UINT8))
    assert out.write_image(np.ascontiguousarray(rgb8))
    out.close()
    return path


def read8(path):
    return oiio.ImageBuf(str(path)).get_pixels(oiio.UINT8).astype(int)


REFERENCE = {}  # the numpy forward pass, once per worker: most of these tests' time


CAMERA = rotation(0.2, -0.1)


def write_scene(tmp_path):
    """The 2DGS scene (model()) seen by CAMERA from 4 units; its PLY path."""
    ply = tmp_path / "m.ply"
    gsply.write(ply, model())
    scene = tmp_path / "s.xml"
    scene.write_text(f'<scene>{gsply.camera_xml(CAMERA, -4.0 * CAMERA[:, 2], F, W, H)}<background color="1 1 1"/>'
                     f'<object name="g"><gaussianModel file="{ply}"/></object></scene>')
    return scene, ply


def scene_and_rasterizer_png(tmp_path):
    """write_scene's scene and the 8-bit PNG a rasterizer writes of its instant 0, made from the
    numpy reference: floor(clamp(c) * 255 + 0.5)."""
    scene, ply = write_scene(tmp_path)
    R, C = CAMERA, -4.0 * CAMERA[:, 2]
    if "colour" not in REFERENCE:
        REFERENCE["colour"] = ref.render(gsply.read(ply), R, C, F, F, W, H, BACKGROUND)[0]
    colour = REFERENCE["colour"]
    png = write_png(tmp_path / "rasterizer.png", np.floor(np.clip(colour, 0, 1) * 255 + 0.5).astype(np.uint8))
    return scene, png, colour


def sharp(scene, out, *extra):
    proc = run([scene, "--time", 0, "--pixel-filter", "point", "--spp", 1, "-o", out,
                "--preview", out.with_suffix(".png"), "--quiet", *extra])
    assert proc.returncode == 0, proc.stderr
    return out, out.with_suffix(".png")


def compare_main(*args):
    """compare.py's main in this process (a command's start-up was most of these tests' time):
    (exit status, stdout, stderr)."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = compare_script.main([str(a) for a in args])
    return code, out.getvalue(), err.getvalue()


def compare_json(*args):
    code, out, err = compare_main(*args, "--json", "-")
    assert code == 0, err
    return json.loads(out[out.index("\n[") + 1:]), out


def stated_colour_space(path):
    """oiio:ColorSpace as the EXR file itself holds it, None when absent (OpenImageIO would say
    Linear): read here from the header's bytes (OpenEXR file layout: magic and version, then
    name NUL type NUL int32 size value, up to an empty name), not through imagecompare."""
    data = path.read_bytes()
    pos = 8
    while data[pos] != 0:
        name_end = data.index(b"\0", pos)
        type_end = data.index(b"\0", name_end + 1)
        size = int.from_bytes(data[type_end + 1:type_end + 5], "little")
        if data[pos:name_end] == b"oiio:ColorSpace":
            return data[type_end + 5:type_end + 5 + size].decode()
        pos = type_end + 5 + size
    return None


def test_default_gaussian_render_previews_and_scores_as_the_rasterizer_frame(tmp_path):
    """Done when of issue 55: the preview is the rasterizer's PNG within 1 level on >= 99.9 % of
    pixels, compare.py scores the EXR against that PNG at >= 45 dB with default options, and says
    both are sRGB. Before: the EXR said nothing (read as Linear), the preview encoded the model's
    colours a second time (0.599 -> 203 instead of 153) and the score was 16.8 dB."""
    scene, png, colour = scene_and_rasterizer_png(tmp_path)
    # the scene is one where encoding twice shows: a fifth of the values (most of the splats) would move
    # by more than 5 levels
    twice = np.round(imagecompare.flip.linear_to_srgb(colour) * 255)
    assert np.mean(np.abs(twice - read8(png)) > 5) > 0.2
    exr, preview = sharp(scene, tmp_path / "gt.exr")
    assert np.mean(np.abs(read8(preview) - read8(png)) <= 1) >= 0.999
    rows, text = compare_json(exr, png)
    assert rows[0]["PSNR"] >= 45
    assert stated_colour_space(exr) == "sRGB" and rows[0]["warnings"] is None
    assert rows[0]["reference encoding"].startswith("srgb") and rows[0]["test encoding"].startswith("srgb")
    assert "encoding: reference srgb" in text


def test_linear_blur_space_says_linear_and_still_previews_the_rasterizer_frame(tmp_path):
    """--blur-space linear decodes every sample: the EXR holds linear light and says so; the preview
    encodes it back, which for a sharp instant is the clamped model colour again."""
    scene, png, _ = scene_and_rasterizer_png(tmp_path)
    exr, preview = sharp(scene, tmp_path / "lin.exr", "--blur-space", "linear")
    assert stated_colour_space(exr) == "Linear"
    assert np.mean(np.abs(read8(preview) - read8(png)) <= 1) >= 0.999
    rows, _ = compare_json(exr, png)
    assert rows[0]["PSNR"] >= 45 and rows[0]["reference encoding"].startswith("linear")


def test_a_surfel_scene_is_linear_light(tmp_path):
    scene = tmp_path / "s.xml"
    scene.write_text('<scene><camera position="0 0 5" lookat="0 0 0" width="8" height="8" fov="30"/>'
                     '<object><sphere radius="0.6" color="0.5 0.5 0.5"/><material shading="unlit"/></object>'
                     '</scene>')
    exr, preview = sharp(scene, tmp_path / "s.exr")
    assert stated_colour_space(exr) == "Linear"
    centre = read8(preview)[4, 4]
    assert np.all(centre == round(imagecompare.flip.linear_to_srgb(0.5) * 255))  # 188: encoded once


def test_differing_blur_spaces_and_assumed_encodings_are_said(tmp_path):
    """A model-space render against a linear-space one, and a float file that states no encoding:
    the JSON and the printed output say so (before: nothing said)."""
    scene, _ = write_scene(tmp_path)
    model_exr, _ = sharp(scene, tmp_path / "m.exr")
    linear_exr, _ = sharp(scene, tmp_path / "l.exr", "--blur-space", "linear")
    rows, text = compare_json(linear_exr, model_exr)
    assert "blur space model" in rows[0]["warnings"] and "in linear" in rows[0]["warnings"]
    assert "warning:" in text
    assert rows[0]["PSNR"] > 45  # sharp: the two spaces hold the same colours, each decoded as stated
    plain = tmp_path / "plain.exr"
    buf = oiio.ImageBuf(np.full((H, W, 3), 0.5, np.float32))
    assert buf.write(str(plain))
    rows, _ = compare_json(linear_exr, plain)
    assert "not stated" in rows[0]["warnings"] and "plain.exr" in rows[0]["warnings"]


def test_an_older_refrender_exr_is_read_by_its_blur_space(tmp_path):
    """A refrender EXR from before oiio:ColorSpace: a Gaussian scene's model colours are sRGB."""
    old = tmp_path / "old.exr"
    buf = oiio.ImageBuf(np.full((4, 4, 3), 0.5, np.float32))
    buf.specmod().attribute("refrender:blurSpace", "model")
    buf.specmod().attribute("refrender:gaussians", "g: semantics=2dgs")
    assert buf.write(str(old))
    img = imagecompare.read_image(old)
    assert img.colorspace == "srgb" and img.encoding.known
    assert np.allclose(img.rgb, imagecompare.flip.srgb_to_linear(0.5))


def write_channels(path, planes):
    names = list(planes)
    spec = oiio.ImageSpec(W, H, len(names), oiio.FLOAT)
    spec.channelnames = tuple(names)
    out = oiio.ImageOutput.create(str(path))
    assert out.open(str(path), spec)
    assert out.write_image(np.ascontiguousarray(np.stack([planes[n] for n in names], axis=-1).astype(np.float32)))
    out.close()
    return path


def test_channels_are_found_by_name_and_a_missing_one_is_refused(tmp_path):
    """The same pixels under Blender's names score as under plain ones (0 error); a file without B,
    or with alpha only, is refused naming what it has (before: channel 0 stood in, exit 0)."""
    rng = np.random.default_rng(3)
    r, g, b, a = (rng.uniform(0, 1, (H, W)) for _ in range(4))
    plain = write_channels(tmp_path / "plain.exr", {"A": a, "B": b, "G": g, "R": r})
    blender = write_channels(tmp_path / "blender.exr", {"Combined.A": a, "Combined.B": b, "Combined.G": g,
                                                        "Combined.R": r, "Depth.Z": a})
    layered = write_channels(tmp_path / "layer.exr", {"ViewLayer.Combined.B": b, "ViewLayer.Combined.G": g,
                                                      "ViewLayer.Combined.R": r, "ViewLayer.DiffCol.B": a,
                                                      "ViewLayer.DiffCol.G": a, "ViewLayer.DiffCol.R": a})
    for other in (blender, layered):
        rows, _ = compare_json(plain, other)
        assert rows[0]["RMSE"] == 0.0
    img = imagecompare.read_image(blender)
    assert np.array_equal(img.alpha, a.astype(np.float32).astype(np.float64))
    for name, planes, said in (("nob.exr", {"A": a, "G": g, "R": r}, "no channel B"),
                               ("alpha.exr", {"A": a}, "channels found: A"),
                               ("two.exr", {"L1.R": r, "L1.G": g, "L1.B": b, "L2.R": r, "L2.G": g, "L2.B": b},
                                "several colour layers")):
        bad = write_channels(tmp_path / name, planes)
        code, _, err = compare_main(plain, bad)
        assert code == 2 and said in err and name in err, err


def test_nframe_procedures_say_their_encoding_and_score_as_decoded(tmp_path):
    """nframe_average.py's procedure outputs are display (sRGB-encoded) values: they say so, and
    compare.py's default score equals its score with --test-colorspace srgb and the script's own
    linear RMSE (before: read as linear, 19 dB where 46 to 70 were right)."""
    ply = tmp_path / "g.ply"
    gsply.write(ply, {"mean": np.zeros((1, 3)), "scale": np.array([[0.08, 0.05]]), "rot": np.array([[1.0, 0, 0, 0]]),
                      "opacity": np.array([0.8]), "sh": ((np.array([0.9, 0.6, 0.2]) - 0.5) / 0.28209479177387814)
                      .reshape(1, 1, 3), "degree": 0})
    scene = tmp_path / "s.xml"
    scene.write_text('<scene><camera position="0 0 0" lookat="0 0 1" up="0 1 0" fov="30" width="24" height="12"/>'
                     '<shutter open="0" close="1"/><background color="0.1 0.2 0.3"/>'
                     f'<object name="g" position="-0.5 0 3"><gaussianModel file="{ply}"/>'
                     '<animation><linear velocity="1 0 0"/></animation></object></scene>')
    gt = tmp_path / "gt.exr"
    assert run([scene, "--batches", 2, "--spp", 1, "--tspp", 64, "--sampler", "sobol", "--blur-space", "linear",
                "--pixel-filter", "point", "--quiet", "-o", gt]).returncode == 0
    out = tmp_path / "rows.json"
    proc = subprocess.run([sys.executable, str(NFRAME), str(scene), "--reference", str(gt), "--out",
                           str(tmp_path / "nf"), "--procedure", "midpoint,bad-gaussians", "--json", str(out),
                           "--", "--spp", "1"], capture_output=True, text=True, env={**os.environ, "REFRENDER": BIN})
    assert proc.returncode == 0, proc.stderr
    linear_rmse = {r["procedure"]["name"]: r["linear"]["RMSE"] for r in json.loads(out.read_text())["rows"]}
    warnings = {}
    for name, blur in (("midpoint", "linear"), ("bad-gaussians", "clamped")):
        result = tmp_path / "nf" / f"procedure_{name}.exr"
        auto, _ = compare_json(gt, result)
        told, _ = compare_json(gt, result, "--test-colorspace", "srgb")
        assert auto[0]["PSNR"] == told[0]["PSNR"]
        # the reference's values all lie in [0, 1] here, where the script's clip changes nothing
        assert abs(auto[0]["RMSE"] - linear_rmse[name]) <= 1e-6 + 1e-3 * linear_rmse[name]
        assert stated_colour_space(result) == "sRGB"
        assert imagecompare.read_image(result).blur_space == blur
        warnings[name] = auto[0]["warnings"]
    # BlenderCV averages the encoded values: not the linear reference's average, and said
    assert warnings["midpoint"] is None and "blur space clamped" in warnings["bad-gaussians"]


def test_gallery_and_cost_error_read_encodings_and_channels(tmp_path):
    """gallery.py shows a Gaussian render as its preview does (before: encoded twice); cost_error.py
    scores Blender-named channels as plain ones."""
    import cost_error
    import gallery
    scene, png, _ = scene_and_rasterizer_png(tmp_path)
    exr, preview = sharp(scene, tmp_path / "gt.exr")
    tile = np.round(gallery.tile(str(exr), None) * 255)
    assert np.abs(tile - read8(preview)).max() <= 1
    channels, _, _ = imagecompare.read_channels(exr)
    blender = write_channels(tmp_path / "b.exr", {f"Combined.{c}": channels[c] for c in "RGBA"})
    plain = write_channels(tmp_path / "p.exr", {c: channels[c] for c in "RGBA"})
    (_, _, _, rmse, _), = cost_error.measure(str(plain), [("m", str(blender), 1.0)])
    assert rmse == 0.0


def test_merged_states_keep_what_their_rgb_holds(tmp_path):
    """`merge` writes the states' colour space with their pixels (a merged Gaussian render that
    said nothing would be read as linear light again)."""
    scene, _ = write_scene(tmp_path)
    states = [tmp_path / f"p{k}.exr" for k in range(2)]
    for k, state in enumerate(states):
        assert run([scene, "--spp", 1, "--tspp", 2, "--batches", 2, "--pass", f"{k}/2", "-o", state,
                    "--quiet"]).returncode == 0
    merged = tmp_path / "merged.exr"
    proc = run(["merge", *states, "-o", merged])
    assert proc.returncode == 0, proc.stderr
    assert stated_colour_space(merged) == "sRGB"


def png_chunks(path):
    """(type, data) of each chunk, read from the bytes (PNG spec section 5.3)."""
    data = path.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    chunks, pos = [], 8
    while pos < len(data):
        size = int.from_bytes(data[pos:pos + 4], "big")
        chunks.append((data[pos + 4:pos + 8], data[pos + 8:pos + 8 + size]))
        pos += 12 + size
    return chunks


def test_a_png_preview_says_srgb_in_its_own_chunks_and_other_formats_hold_the_same_pixels(tmp_path):
    """PNG previews are written by libpng, other formats by OpenImageIO (a 0.75 s load). Either
    way a reader must see an sRGB image: PNG's sRGB chunk and gAMA 1/2.2 (45455, PNG spec 11.3.3.2
    and 11.3.3.5), as OpenImageIO wrote them; a BMP preview holds the PNG's pixels; and a format
    whose writer leaves an unreadable file (OpenImageIO 2.4's TIFF through memory: no directory)
    is refused by name before the render, not written."""
    scene, _, _ = scene_and_rasterizer_png(tmp_path)
    exr, preview = sharp(scene, tmp_path / "r.exr")
    chunks = dict(png_chunks(preview))
    assert chunks[b"IHDR"][8:10] == bytes([8, 2])  # 8-bit truecolour
    assert b"sRGB" in chunks and int.from_bytes(chunks[b"gAMA"], "big") == 45455
    args = [scene, "--time", 0, "--pixel-filter", "point", "--spp", 1, "--quiet"]
    bmp, tif = tmp_path / "r.bmp", tmp_path / "r.tif"
    proc = run([*args, "-o", tmp_path / "b.exr", "--preview", bmp])
    assert proc.returncode == 0, proc.stderr
    assert np.array_equal(read8(preview), read8(bmp))
    assert np.ptp(read8(preview)) > 50  # an image, not a flat field
    proc = run([*args, "-o", tmp_path / "t.exr", "--preview", tif])
    assert proc.returncode != 0 and str(tif) in proc.stderr and "read back" in proc.stderr
    assert not tif.exists() and not (tmp_path / "t.exr").exists()
