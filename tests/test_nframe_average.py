"""scripts/nframe_average.py: the N-frame averages deblurring benchmarks
use, measured against refrender's time integral. Expectations from the
quadrature they are: a still scene's average is the reference for every N
(only the reference's noise differs); a Gaussian crossing the image is a
smooth integrand in time, whose midpoint-rule error falls as N^-2, so 4
times the frames must cut the error by more than 8 (a left-endpoint rule,
times k / N, falls only as N^-1: a ratio near 4); non-box a(t) and bad
inputs are refused by name."""
import json
import os
import subprocess
import sys

import numpy as np
import pytest

import gsply
from conftest import BIN, ROOT

SCRIPT = ROOT / "scripts" / "nframe_average.py"


def write_scene(tmp_path, velocity, weight="box"):
    ply = tmp_path / "g.ply"
    colour = np.array([0.9, 0.6, 0.2])
    gsply.write(ply, {"mean": np.zeros((1, 3)), "scale": np.array([[0.08, 0.05]]), "rot": np.array([[1.0, 0, 0, 0]]),
                      "opacity": np.array([0.8]), "sh": ((colour - 0.5) / 0.28209479177387814).reshape(1, 1, 3),
                      "degree": 0})
    scene = tmp_path / "s.xml"
    scene.write_text(f'<scene><camera position="0 0 0" lookat="0 0 1" up="0 1 0" fov="30" width="24" height="12"/>'
                     f'<shutter open="0" close="1" weight="{weight}"/><background color="0.1 0.2 0.3"/>'
                     f'<object name="g" position="-0.5 0 3"><gaussianModel file="{ply}"/>'
                     f'<animation><linear velocity="{velocity} 0 0"/></animation></object></scene>')
    return scene


def nframe(tmp_path, scene, counts, *extra):
    out = tmp_path / "rows.json"
    args = [scene, "--n", counts, "--out", tmp_path / "nf", "--json", out, "--", "--pixel-filter", "point",
            "--spp", 1, "--tspp", 1024, "--sampler", "sobol", *extra]
    proc = subprocess.run([sys.executable, str(SCRIPT), *map(str, args)],
                          capture_output=True, text=True, env={**os.environ, "REFRENDER": BIN})
    return proc, (json.loads(out.read_text())["rows"] if proc.returncode == 0 else None)


def test_a_still_scene_averages_to_the_reference_for_every_n(tmp_path):
    proc, rows = nframe(tmp_path, write_scene(tmp_path, 0.0), "1,3")
    assert proc.returncode == 0, proc.stderr
    for r in rows:
        assert r["RMSE*"] < 1e-6 and r["within 3 SE"] == 1.0, r
    assert "| 3 |" in proc.stdout  # the table


def test_the_midpoint_rule_error_falls_as_n_squared(tmp_path):
    proc, rows = nframe(tmp_path, write_scene(tmp_path, 1.0), "4,16")
    assert proc.returncode == 0, proc.stderr
    e4, e16 = rows[0]["RMSE*"], rows[1]["RMSE*"]
    assert e4 > 1e-3  # the motion matters at 4 frames
    assert e4 / e16 > 8, (e4, e16)


def test_what_it_cannot_compare_is_refused_by_name(tmp_path):
    proc, _ = nframe(tmp_path, write_scene(tmp_path, 1.0, weight="linear"), "4")
    assert proc.returncode == 1 and "approximates a box a(t) only" in proc.stderr
    proc, _ = nframe(tmp_path, tmp_path / "missing.xml", "4")
    assert proc.returncode == 1 and "missing.xml: no such scene file" in proc.stderr
    sharp = tmp_path / "sharp.exr"
    assert subprocess.run([BIN, str(write_scene(tmp_path, 1.0)), "--time", "0.5", "-o", str(sharp), "--quiet"]).returncode == 0
    proc = subprocess.run([sys.executable, str(SCRIPT), str(tmp_path / "s.xml"), "--reference", str(sharp)],
                          capture_output=True, text=True, env={**os.environ, "REFRENDER": BIN})
    assert proc.returncode == 1 and "no standard errors" in proc.stderr


def _reference(tmp_path, scene, name, *args):
    ref = tmp_path / name
    proc = subprocess.run([BIN, str(scene), "--batches", "2", "--spp", "1", "--tspp", "8", "--quiet", "-o", str(ref),
                           *map(str, args)], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    return ref


def _against(tmp_path, scene, ref, *extra):
    return subprocess.run([sys.executable, str(SCRIPT), str(scene), "--n", "2", "--reference", str(ref), "--out",
                           str(tmp_path / "nf"), *map(str, extra)], capture_output=True, text=True,
                          env={**os.environ, "REFRENDER": BIN})


def test_a_reference_of_another_scene_size_or_crop_is_refused_by_name(tmp_path):
    """A reference must be of the scene the frames are rendered from (issue 32.6): another scene, -D
    parameters, a crop window or another --res gave a plausible table or a traceback."""
    scene = write_scene(tmp_path, 1.0)
    other = tmp_path / "other"
    other.mkdir()
    other_ref = _reference(tmp_path, write_scene(other, 0.5), "other.exr")
    proc = _against(tmp_path, scene, other_ref)
    assert proc.returncode == 1 and "refrender:sceneHash" in proc.stderr and "another scene" in proc.stderr, proc.stderr
    with_param = _reference(tmp_path, scene, "param.exr", "-D", "unused=1")
    proc = _against(tmp_path, scene, with_param)
    assert proc.returncode == 1 and "refrender:parametersHash" in proc.stderr, proc.stderr
    cropped = _reference(tmp_path, scene, "crop.exr", "--crop-window", "0,0.5,0,1")
    proc = _against(tmp_path, scene, cropped)
    assert proc.returncode == 1 and "crop window" in proc.stderr and "Traceback" not in proc.stderr, proc.stderr
    proc = _against(tmp_path, scene, _reference(tmp_path, scene, "whole.exr"), "--", "--res", "12x6")
    assert proc.returncode == 1 and "Traceback" not in proc.stderr, proc.stderr
    (tmp_path / "file").write_text("x")
    proc = subprocess.run([sys.executable, str(SCRIPT), str(scene), "--out", str(tmp_path / "file")],
                          capture_output=True, text=True, env={**os.environ, "REFRENDER": BIN})
    assert proc.returncode == 1 and "not a directory" in proc.stderr and "Traceback" not in proc.stderr, proc.stderr
