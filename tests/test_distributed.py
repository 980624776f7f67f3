"""Distributed rendering without a cluster: what `refrender merge` writes into
the merged header, and the Slurm array script (scripts/slurm-render.sbatch)
and GNU parallel script run with their environments faked. The same script
against a real Slurm is tests/cluster_slurm.py (`make test-cluster`)."""
import os
import struct
import subprocess

import numpy as np
import pytest

from conftest import BIN, ROOT, read_full, run

SBATCH = ROOT / "scripts" / "slurm-render.sbatch"
W, H, SPP, TSPP, BATCHES = 32, 24, 4, 8, 4
# a disc sliding across a 24 fps sequence with a 180-degree shutter
FRAMED = f"""<scene>
 <camera position="0 0 0" lookat="0 0 -1" up="0 1 0" fov="30" width="{W}" height="{H}"/>
 <frames rate="24"/>
 <shutter fraction="0.5"/>
 <object><pointModel><splat center="-1 0 -10" normal="0 0 1" radius="1.2" color="1 0.5 0.25"/></pointModel>
 <material shading="unlit"/><animation><linear velocity="2 0 0"/></animation></object>
</scene>"""
COMMON = ["--batches", BATCHES, "--spp", SPP, "--tspp", TSPP, "--seed", 5, "--quiet"]


def scene_file(tmp_path):
    scene = tmp_path / "framed.xml"
    scene.write_text(FRAMED)
    return scene


def render_ok(*args):
    proc = run(args)
    assert proc.returncode == 0, proc.stderr
    return proc


def passes_of_frame(tmp_path, frame, n=2, args=COMMON):
    scene = scene_file(tmp_path)
    paths = []
    for k in range(n):
        path = tmp_path / f"f{frame}.p{k}.exr"
        render_ok(scene, "--frame", frame, *args, "--pass", f"{k}/{n}", "-o", path)
        paths.append(path)
    return paths


def test_merged_header_is_one_renders_with_the_work_summed(tmp_path):
    # One render and the merge of its two passes: every attribute one render
    # writes is in the merged file; the frame, frame rate, shutter and camera
    # matrices equal (the passes render the same frame from the same camera);
    # rays are the work of both passes: each batch traces one primary ray per
    # sample here (one disc, nothing behind it), W*H*spp*tspp*B in all.
    single = tmp_path / "single.exr"
    render_ok(scene_file(tmp_path), "--frame", 3, *COMMON, "-o", single)
    parts = passes_of_frame(tmp_path, 3)
    merged = tmp_path / "merged.exr"
    render_ok("merge", *parts, "-o", merged)
    one, merged_header = read_full(single)[1], read_full(merged)[1]
    missing = sorted(set(one) - set(merged_header))
    assert missing == [], missing
    for key in ("refrender:frame", "refrender:frameRate", "refrender:shutterOpen", "refrender:shutterClose",
                "worldToCamera", "worldToNDC"):
        assert np.array_equal(np.asarray(one[key]), np.asarray(merged_header[key])), key
    assert merged_header["refrender:frame"] == 3 and merged_header["refrender:frameRate"] == 24
    assert merged_header["refrender:rays"] == one["refrender:rays"] == W * H * SPP * TSPP * BATCHES
    seconds = [read_full(p)[1]["refrender:renderSeconds"] for p in parts]
    assert merged_header["refrender:renderSeconds"] == pytest.approx(sum(seconds), abs=1.5e-3)
    different = {k for k in one if k not in ("refrender:command", "refrender:renderSeconds")
                 and not np.array_equal(np.asarray(one[k]), np.asarray(merged_header[k]))}
    assert different == set(), different


def patch_attribute(path, name, type_name, value_bytes):
    """Rewrites one attribute's value in an EXR header in place (name, type,
    size, value: the OpenEXR file layout); the pixels stay as they are."""
    data = bytearray(path.read_bytes())
    tag = name.encode() + b"\0" + type_name.encode() + b"\0" + struct.pack("<i", len(value_bytes))
    at = data.index(tag) + len(tag)
    data[at:at + len(value_bytes)] = value_bytes
    path.write_bytes(bytes(data))


@pytest.mark.parametrize("name,type_name,value", [
    ("refrender:frame", "int", struct.pack("<i", 4)),
    ("refrender:frameRate", "double", struct.pack("<d", 25.0)),
    ("refrender:shutterOpen", "double", struct.pack("<d", 0.1)),
    ("refrender:shutterClose", "double", struct.pack("<d", 0.2)),
    ("worldToCamera", "m44f", struct.pack("<16f", *np.eye(4).ravel() * 2)),
    ("worldToNDC", "m44f", struct.pack("<16f", *np.eye(4).ravel() * 2)),
], ids=lambda v: v if isinstance(v, str) and ":" in v or v in ("worldToCamera", "worldToNDC") else "")
def test_merge_refuses_passes_that_disagree_on(tmp_path, name, type_name, value):
    # A pass numbered as another frame, or seen from another camera, is not a
    # share of this image: the merge names the attribute and both files.
    p0, p1 = passes_of_frame(tmp_path, 3)
    patch_attribute(p1, name, type_name, value)
    out = tmp_path / "merged.exr"
    proc = run(["merge", p0, p1, "-o", out])
    assert proc.returncode == 1, proc.stderr
    assert name in proc.stderr and str(p0) in proc.stderr and str(p1) in proc.stderr, proc.stderr
    assert not out.exists()


def test_merge_refuses_a_pass_that_lacks_the_frame(tmp_path):
    # Frame 0's shutter rendered without --frame: the same pixels, but no
    # frame number to check the sequence by; mixed with numbered passes it is
    # refused, not merged into a header that half says which frame it is.
    (p0,) = passes_of_frame(tmp_path, 0, n=2)[:1]
    unnumbered = tmp_path / "unnumbered.exr"
    render_ok(scene_file(tmp_path), *COMMON, "--pass", "1/2", "-o", unnumbered)
    proc = run(["merge", p0, unnumbered, "-o", tmp_path / "m.exr"])
    assert proc.returncode == 1 and "refrender:frame" in proc.stderr, proc.stderr


def test_merge_of_exact_time_passes_weights_the_unresolved_share_by_rays(tmp_path):
    # The unresolved share is per traced ray: the merged share is the passes'
    # ray-weighted mean, which is one render's share up to the 6 digits the
    # passes store.
    exact = ["--time-integration", "exact", "--batches", BATCHES, "--spp", SPP, "--quiet"]
    single = tmp_path / "single.exr"
    render_ok(scene_file(tmp_path), "--frame", 3, *exact, "-o", single)
    parts = passes_of_frame(tmp_path, 3, args=exact)
    merged = tmp_path / "merged.exr"
    render_ok("merge", *parts, "-o", merged)
    key = "refrender:exactUnresolvedShare"
    headers = [read_full(p)[1] for p in parts]
    rays = [h["refrender:rays"] for h in headers]
    weighted = sum(float(h[key]) * r for h, r in zip(headers, rays)) / sum(rays)
    got = float(read_full(merged)[1][key])
    assert got == pytest.approx(weighted, rel=1e-5, abs=1e-12)
    assert got == pytest.approx(float(read_full(single)[1][key]), rel=1e-4, abs=1e-9)
