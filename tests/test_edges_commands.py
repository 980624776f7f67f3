"""Edges of the commands: 'refrender merge' and 'refrender
surfels' refuse to overwrite their input (the render already did); a state
whose header declares more pixels than its file can hold is refused before
anything is allocated for them; a state holding more batches than its own
range, or a range beyond its render's batches, is called damaged, not
incomplete (pixels beyond the range are what a --target-error checkpoint
holds: the message says so); `merge --preview` writes a single render's
preview and is checked as a render's --preview."""
import struct

from conftest import run

EMPTY = """<scene><camera position="0 0 5" lookat="0 0 0" width="{w}" height="{h}"/>
<background color="0.2 0.3 0.4"/><object><sphere center="100 0 0" radius="1"/></object></scene>"""


def state(tmp_path, name, w, h, batches=2, pass_="0/1"):
    scene = tmp_path / f"{name}.xml"
    scene.write_text(EMPTY.format(w=w, h=h))
    out = tmp_path / f"{name}.exr"
    proc = run([scene, "--spp", 1, "--tspp", 1, "--batches", batches, "--pass", pass_, "-o", out, "--quiet"])
    assert proc.returncode == 0, proc.stderr
    return out


def test_merge_and_surfels_refuse_to_overwrite_their_input(tmp_path):
    st = state(tmp_path, "s", 4, 4)
    before = st.read_bytes()
    proc = run(["merge", st, "-o", tmp_path / "." / "s.exr"])
    assert proc.returncode == 1 and "refusing to overwrite" in proc.stderr
    assert st.read_bytes() == before
    cloud = tmp_path / "c.xyz"
    cloud.write_text("".join(f"{x} {y} 0 0 0 1\n" for x in range(4) for y in range(4)))
    before = cloud.read_bytes()
    proc = run(["surfels", cloud, "-o", cloud])
    assert proc.returncode == 1 and "refusing to overwrite" in proc.stderr
    assert cloud.read_bytes() == before


def patch(data, old, new):
    assert len(old) == len(new) and data.count(old) == 1
    i = data.index(old)
    data[i:i + len(old)] = new


def test_a_state_larger_than_its_file_is_refused_before_allocating(tmp_path):
    # a 1000x1000 state of one colour compresses to about 280 KB; its header
    # is made to say 8192x8192 (7.5 GB of sums): no file that small holds it
    data = bytearray(state(tmp_path, "big", 1000, 1000).read_bytes())
    for name in (b"dataWindow\x00box2i\x00", b"displayWindow\x00box2i\x00"):
        i = data.index(name) + len(name) + 4
        data[i:i + 16] = struct.pack("<4i", 0, 0, 8191, 8191)
    patch(data, b"1000x1000", b"8192x8192")
    crafted = tmp_path / "crafted.exr"
    crafted.write_bytes(bytes(data))
    proc = run(["merge", crafted, "-o", tmp_path / "m.exr"])
    assert proc.returncode == 1 and "too few even at zlib's best ratio" in proc.stderr, proc.stderr


def test_a_state_with_more_batches_than_its_range_is_damaged_not_incomplete(tmp_path):
    data = bytearray(state(tmp_path, "two", 4, 4, batches=4, pass_="0/2").read_bytes())
    patch(data, b"batches 0-2", b"batches 0-1")
    crafted = tmp_path / "crafted.exr"
    crafted.write_bytes(bytes(data))
    proc = run(["merge", crafted, "-o", tmp_path / "m.exr"])
    assert proc.returncode == 1 and "more than the 1 of its range 0-1" in proc.stderr, proc.stderr
    # the one way a render makes such a state: a --target-error checkpoint
    assert "--target-error" in proc.stderr and "resume it first" not in proc.stderr


def test_a_state_beyond_its_renders_batches_is_damaged_not_incomplete(tmp_path):
    # its pixels hold the 2 batches the render gives; its range claims 8 of 2
    data = bytearray(state(tmp_path, "two", 4, 4, batches=2).read_bytes())
    patch(data, b"batches 0-2", b"batches 0-8")
    crafted = tmp_path / "crafted.exr"
    crafted.write_bytes(bytes(data))
    proc = run(["merge", crafted, "-o", tmp_path / "m.exr"])
    assert proc.returncode == 1 and "beyond the 2 batches of its render" in proc.stderr, proc.stderr
    assert "incomplete" not in proc.stderr


def test_surfels_of_coinciding_points_names_the_input_not_the_output(tmp_path):
    cloud = tmp_path / "same.xyz"
    cloud.write_text("0 0 0 0 0 1\n" * 10)
    out = tmp_path / "out.ply"
    proc = run(["surfels", cloud, "-o", out])
    assert proc.returncode == 1 and f"{cloud}: no splat is left of 10 points" in proc.stderr, proc.stderr
    assert "out.ply" not in proc.stderr and not out.exists()


def test_merge_writes_the_preview_a_single_render_writes(tmp_path):
    """`refrender merge --preview`: a parallel render gets its preview, the
    very bytes one process rendering every batch writes with --preview (the
    merged EXR is bit-identical to it); checked as a render's --preview: a
    format OpenImageIO cannot write, a state, or -o's own file is refused
    before anything is written. Before: merge had no --preview."""
    scene = tmp_path / "m.xml"
    scene.write_text(EMPTY.format(w=12, h=8).replace('center="100 0 0"', 'center="0.5 0 0"'))
    states = [tmp_path / f"p{k}.exr" for k in range(2)]
    for k, st in enumerate(states):
        proc = run([scene, "--spp", 1, "--tspp", 2, "--batches", 2, "--pass", f"{k}/2", "-o", st, "--quiet"])
        assert proc.returncode == 0, proc.stderr
    one = run([scene, "--spp", 1, "--tspp", 2, "--batches", 2, "-o", tmp_path / "one.exr", "--preview",
               tmp_path / "one.png", "--quiet"])
    assert one.returncode == 0, one.stderr
    proc = run(["merge", *states, "-o", tmp_path / "m.exr", "--preview", tmp_path / "m.png"])
    assert proc.returncode == 0 and "-> " in proc.stderr and "m.png" in proc.stderr, proc.stderr
    assert (tmp_path / "m.png").read_bytes() == (tmp_path / "one.png").read_bytes()
    before = states[0].read_bytes()
    for preview, says in ((tmp_path / "x.xyz", "no image format"), (states[0], "refusing to overwrite"),
                          (tmp_path / "n.exr", "name the same file")):
        out = tmp_path / "n.exr"
        proc = run(["merge", *states, "-o", out, "--preview", preview])
        assert proc.returncode == 1 and says in proc.stderr, proc.stderr
        assert not out.exists() and states[0].read_bytes() == before
