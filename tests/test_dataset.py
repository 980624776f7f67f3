"""refrender dataset (scripts/dataset.py run by src/cmd/dataset_cmd.c): the datasets it writes read
by loaders written from the methods' own code (deblurnerf_llff_reference.py,
nerfstudio_reference.py), poses against the scene's analytic camera and export, PNG against EXR,
the manifest against the headers, and the hostile cases: an existing output, bad ranges,
interrupt, resume, corrupted frames, parts rendered apart and assembled."""
import json
import math
import os
import shutil
import signal
import subprocess
import time
from pathlib import Path

import numpy as np
import pytest

import deblurnerf_llff_reference as llff_ref
import imagecompare
import nerfstudio_reference as ns_ref
from conftest import BIN, ROOT

# A camera translating by (-1, 0.2, 0) per second from (0, 0, 4), looking down -z, 10 frames a
# second, a 180-degree shutter: frame f is exposed over [f/10, f/10 + 0.05], its middle at
# f/10 + 0.025, where the camera-to-world (OpenGL axes) is the identity rotation at (-t, 0.2 t, 4).
# The vertical field of view is 40 degrees at 16x12: fy = 6 / tan(20 deg) = fx, centre (8, 6).
SCENE = """<scene>
  <camera position="0 0 4" lookat="0 0 0" up="0 1 0" fov="40" width="16" height="12">
    <animation><keyframes>
      <key time="0" translate="0 0 0"/>
      <key time="1" translate="-1 0.2 0"/>
    </keyframes></animation>
  </camera>
  <frames rate="10"/>
  <shutter fraction="0.5" weight="box"/>
  <background color="0.1 0.1 0.1"/>
  <object name="ball"><pointModel generate="sphere" count="2000" radius="0.8" checker="4"
    color="0.9 0.3 0.2" color2="0.2 0.4 0.9"/></object>
</scene>
"""
RENDER = ["--target-error", "2lv", "--", "--spp", "1", "--tspp", "8"]
FOCAL = 6 / math.tan(math.radians(20))


def middle_c2w(frame):
    t = frame / 10 + 0.025
    return np.array([[1, 0, 0, -t], [0, 1, 0, 0.2 * t], [0, 0, 1, 4]], dtype=np.float64)


def dataset(scene, out, layout, frames="0-2", extra=(), **kw):
    opts = ["--bounds", "2,6"] if layout == "llff" else []
    return subprocess.run([BIN, "dataset", scene, "--layout", layout, "--frames", frames, "-o", out, "--hold", "2",
                           *opts, *extra, *RENDER], capture_output=True, text=True, **kw)


@pytest.fixture(scope="module")
def made(tmp_path_factory):
    d = tmp_path_factory.mktemp("dataset")
    scene = d / "scene.xml"
    scene.write_text(SCENE)
    p = dataset(scene, d / "nerfstudio", "nerfstudio")
    assert p.returncode == 0, p.stderr
    # the LLFF layout assembled from the same frames, rendering none (the layout is the assembly's)
    shutil.copytree(d / "nerfstudio/frames", d / "llff.staging/frames")
    shutil.copy(d / "nerfstudio/settings.json", d / "llff.staging")
    p = dataset(scene, d / "llff", "llff", extra=["--assemble"])
    assert p.returncode == 0, p.stderr
    return d


def read_u8(path):
    import OpenImageIO as oiio
    inp = oiio.ImageInput.open(str(path))
    px = inp.read_image(oiio.UINT8)
    inp.close()
    return px


def as_loaded(png):
    """A PNG as load_llff_data holds it: RGB / 255 in float32."""
    return (read_u8(png)[..., :3] / 255.0).astype(np.float32)


def rgb_and_stderr(path):
    ch = imagecompare.read_channels(path, unassociated_alpha=False)[0]
    return np.stack([ch[c] for c in ("R", "G", "B", "stderr.R", "stderr.G", "stderr.B")], axis=-1)


def test_llff_reads_as_deblur_nerf_loads_it(made):
    root = made / "llff"
    images, poses, bds, names, i_train, i_test = llff_ref.load_llff_data(root, factor=1, bd_factor=None, llffhold=2)
    assert names == ["000000.png", "000001.png", "000002.png"]
    assert images.shape == (3, 12, 16, 3)
    for i in range(3):
        assert np.allclose(poses[i, :, :4], middle_c2w(i), atol=1e-6), poses[i]
        assert np.allclose(poses[i, :, 4], [12, 16, FOCAL], rtol=1e-6)
    assert np.array_equal(bds, [[2, 6]] * 3)
    assert list(i_test) == [0, 2] and list(i_train) == [1]
    # held-out views sharp, training views blurred (Deblur-NeRF's synthetic scenes)
    for i, kind in ((0, "sharp"), (1, "blur"), (2, "sharp")):
        assert np.array_equal(images[i], as_loaded(root / f"frames/00000{i}/{kind}.png"))
    assert not np.array_equal(images[0], as_loaded(root / "frames/000000/blur.png"))
    # its default bd_factor scales translations and bounds by 1 / (0.75 min bound)
    _, scaled, sbds, *_ = llff_ref.load_llff_data(root, factor=1, bd_factor=0.75, llffhold=2)
    assert np.allclose(scaled[:, :, 3], poses[:, :, 3] / 1.5, atol=1e-6) and np.allclose(sbds, bds / 1.5)
    assert os.readlink(root / "images") == "images_1"


def test_nerfstudio_reads_as_its_dataparser_parses_it(made):
    root = made / "nerfstudio"
    train, val, test = (ns_ref.parse(root, s) for s in ("train", "val", "test"))
    assert [p.name for p in train["image_filenames"]] == ["frame_000001.png"]
    assert [p.name for p in test["image_filenames"]] == ["frame_000000.png", "frame_000002.png"]
    assert val["image_filenames"] == test["image_filenames"]
    assert (train["fl_x"], train["fl_y"], train["cx"], train["cy"], train["w"], train["h"]) == pytest.approx(
        (FOCAL, FOCAL, 8, 6, 16, 12), rel=1e-12)
    assert train["camera_model"] == "OPENCV" and train["distortion"] == [0.0] * 5
    assert np.allclose(train["camera_to_worlds"][0], middle_c2w(1), atol=1e-6)
    for k, frame in enumerate((0, 2)):
        assert np.allclose(test["camera_to_worlds"][k], middle_c2w(frame), atol=1e-6)
        assert np.array_equal(read_u8(test["image_filenames"][k]), read_u8(root / f"frames/00000{frame}/sharp.png"))
    assert np.array_equal(read_u8(train["image_filenames"][0]), read_u8(root / "frames/000001/blur.png"))
    meta = train["meta"]
    assert meta["exposure_time"] == pytest.approx(0.05) and meta["rolling_shutter_time"] == 0
    assert [f["time"] for f in meta["frames"]] == pytest.approx([0.025, 0.125, 0.225])


def test_poses_are_exports_poses(made):
    """transforms.json's poses are export's middle-of-exposure poses, in double precision."""
    out = made / "export.json"
    subprocess.run([BIN, "export", made / "scene.xml", "--frames", "0-2", "--times", "1", "--axes", "opengl",
                    "-o", out], check=True)
    exported = json.loads(out.read_text())["frames"]
    frames = json.loads((made / "nerfstudio/transforms.json").read_text())["frames"]
    for f, e in zip(frames, exported):
        assert np.allclose(np.linalg.inv(np.array(e["world_to_camera"][1])), f["transform_matrix"], rtol=0, atol=1e-12)


def test_png_is_the_preview_of_the_exr(made):
    """The PNG is the EXR's RGB clamped, sRGB-encoded (its oiio:ColorSpace is Linear), rounded half up."""
    for kind in ("blur", "sharp"):
        ch, _, header = imagecompare.read_channels(made / f"nerfstudio/frames/000001/{kind}.exr", False)
        assert header["oiio:ColorSpace"] == "Linear"
        v = np.clip(np.stack([ch[c] for c in "RGB"], -1).astype(np.float64), 0, 1)
        want = np.floor(255 * np.where(v <= 0.0031308, 12.92 * v, 1.055 * v ** (1 / 2.4) - 0.055) + 0.5)
        got = read_u8(made / f"nerfstudio/frames/000001/{kind}.png")[..., :3].astype(np.float64)
        assert np.abs(got - want).max() <= 1 and (got == want).mean() > 0.99


def test_manifest_states_the_noise_reached(made):
    m = json.loads((made / "nerfstudio/manifest.json").read_text())
    build = subprocess.run([BIN, "--version"], capture_output=True, text=True).stdout.split("build ")[1].rstrip(")\n")
    assert m["build"] == build and m["command"].startswith(f"{BIN} dataset ") and m["blur_space"] == "model"
    for f in m["frames"]:
        path = made / "nerfstudio" / f["blur"]["exr"]
        header = imagecompare.read_channels(path, False)[2]
        se = rgb_and_stderr(path)[..., 3:].max(axis=-1)
        assert f["noise"]["stderrMax"] == pytest.approx(float(se.max()), rel=1e-6)
        assert f["noise"]["stderrMax"] == header["refrender:stderrMax"]
        assert f["noise"]["target_reached"] == (se.max() <= 2 / 255)
        assert f["split"] == ("train" if f["frame"] == 1 else "test")
    assert m["noise_max"] == max(f["noise"]["stderrMax"] for f in m["frames"])


@pytest.mark.parametrize("args, message", [
    (["--frames", "2-1"], "--frames"), (["--frames", "x"], "--frames"), (["--frames", "-1-2"], "--frames"),
    (["--frames", "0-0", "--", "-o", "x.exr"], "-o: set by refrender dataset"),
])
def test_bad_arguments_are_refused_before_anything_is_written(tmp_path, args, message):
    scene = tmp_path / "scene.xml"
    scene.write_text(SCENE)
    p = subprocess.run([BIN, "dataset", scene, "--layout", "nerfstudio", "-o", tmp_path / "out", *args],
                       capture_output=True, text=True)
    assert p.returncode in (1, 2) and message in p.stderr, p.stderr  # 2: argparse's usage error
    assert sorted(x.name for x in tmp_path.iterdir()) == ["scene.xml"]


def test_usage_errors(tmp_path):
    p = subprocess.run([BIN, "dataset", "s.xml", "--layout", "llff", "--frames", "0-1", "-o", tmp_path / "o"],
                       capture_output=True, text=True)
    assert p.returncode == 2 and "--bounds" in p.stderr
    p = subprocess.run([BIN, "dataset", tmp_path / "none.xml", "--layout", "nerfstudio", "--frames", "0-1", "-o",
                        tmp_path / "o"], capture_output=True, text=True)
    assert p.returncode == 1 and "none.xml" in p.stderr
    assert "REFRENDER-ARGS" in subprocess.run([BIN, "dataset", "--help"], capture_output=True, text=True).stdout


def test_an_existing_output_is_left_alone(tmp_path):
    scene = tmp_path / "scene.xml"
    scene.write_text(SCENE)
    (tmp_path / "out").mkdir()
    (tmp_path / "out/keep.txt").write_text("mine")
    p = dataset(scene, tmp_path / "out", "nerfstudio", "0-0")
    assert p.returncode == 1 and "exists" in p.stderr
    assert [x.name for x in (tmp_path / "out").iterdir()] == ["keep.txt"]
    assert not (tmp_path / "out.staging").exists()


def wait_for_sigint_handler(proc):
    """Until the process catches SIGINT (Python's own handler; conftest.wait_for_handlers also wants
    SIGTERM, which Python leaves at its default)."""
    while proc.poll() is None:
        status = Path(f"/proc/{proc.pid}/status").read_text()
        if int(next(l for l in status.splitlines() if l.startswith("SigCgt:")).split()[1], 16) & 2:
            return
        time.sleep(0.001)
    raise AssertionError("the process ended before it caught SIGINT")


def stalling_refrender(tmp_path, frame):
    """A refrender for the dataset's renders that stalls at frame `frame`'s blurred render, after writing
    the marker it returns: the interrupt then lands while that frame renders however loaded the machine
    (a real render's moment could not be caught: a loaded run once ended all frames before SIGINT).
    `refrender dataset` renders with its own binary whatever REFRENDER says, so the script it runs
    (scripts/dataset.py, same arguments) is run with REFRENDER set to this one."""
    marker, wrapper = tmp_path / "stalled", tmp_path / "refrender-stalling"
    wrapper.write_text(f"""#!/bin/sh
case " $* " in *" --frame {frame} -o "*) : > '{marker}'; exec sleep 60;; esac
exec '{BIN}' "$@"
""")
    wrapper.chmod(0o755)
    return wrapper, marker


def test_interrupt_leaves_no_dataset_and_the_same_command_resumes(tmp_path, made):
    scene = tmp_path / "scene.xml"
    scene.write_text(SCENE)
    out, staging = tmp_path / "ds", tmp_path / "ds.staging"
    opts = ["--layout", "nerfstudio", "--frames", "0-1", "-o", out, "--hold", "2"]
    wrapper, stalled = stalling_refrender(tmp_path, 1)  # frame 0 complete, frame 1 rendering
    proc = subprocess.Popen(["/usr/bin/python3", ROOT / "scripts/dataset.py", scene, *opts, *RENDER],
                            stderr=subprocess.PIPE, text=True, start_new_session=True,
                            env={**os.environ, "REFRENDER": str(wrapper)})
    try:
        while not stalled.exists() and proc.poll() is None:
            time.sleep(0.001)
        wait_for_sigint_handler(proc)
        os.killpg(proc.pid, signal.SIGINT)  # as Ctrl-C reaches the whole foreground group
        _, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 130, err
    assert not out.exists() and "no dataset written" in err
    kept = (staging / "frames/000000/blur.exr").stat().st_ino
    p = subprocess.run([BIN, "dataset", scene, *opts, *RENDER], capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
    assert "frame 0 already complete" in p.stderr and not staging.exists()
    assert (out / "frames/000000/blur.exr").stat().st_ino == kept
    # a seed gives the same pixels whether the dataset was made in one run or resumed
    for f in range(2):
        for kind in ("blur", "sharp"):
            assert np.array_equal(rgb_and_stderr(out / f"frames/00000{f}/{kind}.exr"),
                                  rgb_and_stderr(made / f"nerfstudio/frames/00000{f}/{kind}.exr"))


def test_parts_rendered_apart_assemble_and_a_corrupted_frame_is_rendered_again(tmp_path, made):
    scene = tmp_path / "scene.xml"
    scene.write_text(SCENE)
    out, staging = tmp_path / "ds", tmp_path / "ds.staging"
    p = dataset(scene, out, "llff", "0-0", ["--no-assemble"])
    assert p.returncode == 0 and not out.exists(), p.stderr
    # frames 1 and 2 as another machine would leave them in the shared staging directory: the
    # made dataset's, same scene and settings (its scene file is another copy of the same bytes)
    settings = json.loads((made / "llff/settings.json").read_text())
    assert {k: v for k, v in settings.items() if k != "scene"} == {
        k: v for k, v in json.loads((staging / "settings.json").read_text()).items() if k != "scene"}
    for f in (1, 2):
        shutil.copytree(made / f"llff/frames/00000{f}", staging / f"frames/00000{f}")
    p = dataset(scene, out, "llff", "0-3", ["--assemble"])
    assert p.returncode == 1 and "frame 3 is missing" in p.stderr and not out.exists()
    other = subprocess.run([BIN, "dataset", scene, "--layout", "llff", "--bounds", "2,6", "--frames", "0-2", "-o",
                            out, "--target-error", "1lv", "--", "--spp", "1", "--tspp", "8"],
                           capture_output=True, text=True)
    assert other.returncode == 1 and "other settings (target_error" in other.stderr
    png = staging / "frames/000001/blur.png"
    png.write_bytes(png.read_bytes()[:-1] + bytes([png.read_bytes()[-1] ^ 1]))
    p = dataset(scene, out, "llff", "0-2", ["--assemble"])
    assert p.returncode == 1 and "frame 1 is missing or incomplete" in p.stderr
    p = dataset(scene, out, "llff", "0-2")
    assert p.returncode == 0, p.stderr
    assert "frame 0 already complete" in p.stderr and "frame 2 already complete" in p.stderr
    assert "frame 1 (2/3)" in p.stderr
    a, b = (np.load(d / "poses_bounds.npy") for d in (out, made / "llff"))
    assert np.array_equal(a, b)
    for f in range(3):
        new, old = (d / f"frames/00000{f}/blur.png" for d in (out, made / "llff"))
        assert new.read_bytes() == old.read_bytes()


def test_an_n_frame_procedure_beside_the_true_blur(tmp_path):
    scene = tmp_path / "scene.xml"
    scene.write_text(SCENE)
    p = dataset(scene, tmp_path / "ds", "nerfstudio", "1-1", ["--procedure", "deblur-nerf"])
    assert p.returncode == 0, p.stderr
    d = tmp_path / "ds/frames/000001"
    assert sorted(x.name for x in (d / "nframe").iterdir()) == ["deblur-nerf.exr", "deblur-nerf.png"]
    assert not (d / "nframe_scratch").exists()
    done = json.loads((d / "done.json").read_text())
    assert "nframe/deblur-nerf.png" in done["files"]
    # Deblur-NeRF's 8-bit frames and truncation: every value a whole level, unlike the integral
    ch = imagecompare.read_channels(d / "nframe/deblur-nerf.exr", False)[0]
    assert np.array_equal(ch["R"] * 255, np.round(ch["R"] * 255))


def test_a_rolling_shutter_in_transforms_json(tmp_path):
    """3dgs-deblur's convention (scenes/examples/rolling_shutter.xml as frames): its readout as
    rolling_shutter_time, and the sharp view at the blurred one's camera time, where --time centres
    the lines as the exposure does (the middle line's instant, src/TRAJECTORIES.md)."""
    scene = tmp_path / "rs.xml"
    scene.write_text(SCENE.replace('<shutter fraction="0.5" weight="box"/>',
                                   '<shutter fraction="0.5" rolling="3dgs-deblur" readoutTime="0.08"/>'))
    p = dataset(scene, tmp_path / "ds", "nerfstudio", "1-1")
    assert p.returncode == 0, p.stderr
    meta = json.loads((tmp_path / "ds/transforms.json").read_text())
    assert meta["rolling_shutter_time"] == 0.08 and meta["exposure_time"] == pytest.approx(0.05)
    assert meta["frames"][0]["rolling_shutter"]["kind"] == "3dgs-deblur"
    times = [imagecompare.read_channels(tmp_path / f"ds/frames/000001/{k}.exr", False)[2]["refrender:cameraTime"]
             for k in ("blur", "sharp")]
    assert times[0] == times[1] == pytest.approx(meta["frames"][0]["time"])


def test_a_transforms_json_camera_off_centre(tmp_path):
    """A camera as nerfstudio wrote it (scenes/examples/transforms.json: principal point (34, 22.5)
    in 64x48, fl 70): LLFF cannot say it and is refused before anything renders; the nerfstudio
    layout gives its intrinsics back exactly, as its dataparser reads them."""
    examples = Path(__file__).resolve().parent.parent / "scenes/examples"
    for name in ("transforms.json", "sphere_3dgs.ply"):
        shutil.copy(examples / name, tmp_path)
    scene = tmp_path / "scene.xml"
    scene.write_text((examples / "transforms.xml").read_text().replace("<shutter", '<frames rate="1"/><shutter'))
    p = dataset(scene, tmp_path / "llff", "llff", "0-0")
    assert p.returncode == 1 and "use --layout nerfstudio" in p.stderr and "(34, 22.5)" in p.stderr, p.stderr
    assert not (tmp_path / "llff.staging").exists()
    p = dataset(scene, tmp_path / "ns", "nerfstudio", "0-0")
    assert p.returncode == 0, p.stderr
    test = ns_ref.parse(tmp_path / "ns", "test")
    assert (test["fl_x"], test["fl_y"], test["cx"], test["cy"], test["w"], test["h"]) == pytest.approx(
        (70, 70, 34, 22.5, 64, 48), rel=1e-12)  # export's doubles: the camera's own, through its fov
