"""Identity and attribute text is never cut silently.
The parameters and the weight function enter a render's identity whole,
through their hashes (refrender:parametersHash, refrender:weightHash):
their text was cut at 4095 characters, so passes rendered with -D vx=0 and
-D vx=2.5 after a long parameter list merged. A 256-pair weight table
written one pair per line is read whole (252 pairs were kept), and an
over-long attribute is refused naming its length instead of being cut (a
4110-character file= path rendered a different, existing file); and
an external entity as a model path is named (it read as an empty path,
"point model has no splats")."""
import json

from conftest import BIN, read_full, run

LONG = "x" * 500
SCENE = """<scene><camera position="0 0 5" lookat="0 0 0" width="4" height="4"/>
<object><sphere radius="0.5"/><animation><linear velocity="$vx 0 0"/></animation></object></scene>"""


def test_parameters_differing_after_4095_characters_do_not_merge(tmp_path):
    scene = tmp_path / "s.xml"
    scene.write_text(SCENE)
    many = [a for i in range(10) for a in ("-D", f"p{i}={LONG}")]  # about 5000 characters first
    for k, vx in enumerate(["0", "2.5"]):
        proc = run([scene, *many, "-D", f"vx={vx}", "--spp", 1, "--tspp", 2, "--batches", 2, "--pass", f"{k}/2",
                    "-o", tmp_path / f"p{k}.exr", "--quiet"])
        assert proc.returncode == 0, proc.stderr
    proc = run(["merge", tmp_path / "p0.exr", tmp_path / "p1.exr", "-o", tmp_path / "m.exr"])
    assert proc.returncode == 1 and "refrender:parametersHash" in proc.stderr, proc.stderr
    header = read_full(tmp_path / "p0.exr")[1]
    assert "cut: the whole text's hash is the identity" in header["refrender:parameters"]


def test_a_256_pair_table_one_pair_per_line_is_read_whole(tmp_path):
    # 256 lines of 72 characters: 18 KB, past the 16 KB buffer that cut it
    pairs = "\n".join(f"    {i / 255:.30f} {1 + (i == 255) * 9:.30f}" for i in range(256))
    scene = tmp_path / "t.xml"
    scene.write_text(f"""<scene><camera position="0 0 5" lookat="0 0 0" width="4" height="4"/>
<shutter open="0" close="1" weight="table" table="{pairs}"/><object><sphere radius="0.5"/></object></scene>""")
    proc = run(["export", scene, "-o", tmp_path / "t.json"])
    assert proc.returncode == 0, proc.stderr
    table = json.loads((tmp_path / "t.json").read_text())["frames"][0]["weight"]["table"]
    assert len(table) == 256 and table[-1] == [1.0, 10.0]


def test_an_over_long_path_is_refused_not_cut(tmp_path):
    (tmp_path / "a.ply").write_text("ply\n")
    path = str(tmp_path / "a.ply") + "/" * 4100  # names a.ply if cut at 4095 characters
    scene = tmp_path / "l.xml"
    scene.write_text(f"""<scene><object><pointModel file="{path}"/></object></scene>""")
    proc = run([scene, "-o", tmp_path / "l.exr"])
    assert proc.returncode == 1 and "attribute 'file' is" in proc.stderr and "characters long" in proc.stderr
    assert "l.xml:1" in proc.stderr


def test_an_external_entity_in_a_path_is_named(tmp_path):
    scene = tmp_path / "e.xml"
    scene.write_text("""<?xml version="1.0"?><!DOCTYPE scene [<!ENTITY ext SYSTEM "model.ply">]>
<scene><object><pointModel>&ext;</pointModel></object></scene>""")
    proc = run([scene, "-o", tmp_path / "e.exr"])
    assert proc.returncode == 1, proc.stderr
    assert "no splats" not in proc.stderr and "external XML entity 'ext'" in proc.stderr, proc.stderr


def test_the_command_attribute_holds_a_long_command_line_whole(tmp_path):
    # refrender:command is the arguments joined by spaces: a 3,000-character
    # command line (long -D values) is kept whole; a 2 KB buffer cut it
    # silently.
    scene = tmp_path / "s.xml"
    scene.write_text(SCENE.replace("$vx", "0"))
    out = tmp_path / "o.exr"
    params = [a for k in range(8) for a in ("-D", f"unused{k}=" + "y" * 400)]  # a value holds at most 511
    args = [scene, *params, "--spp", 1, "--tspp", 1, "--quiet", "-o", out]
    proc = run(args)
    assert proc.returncode == 0, proc.stderr
    command = read_full(out)[1]["refrender:command"]
    # (getopt has moved the scene after the options by then)
    assert sorted(command.split(" ")) == sorted(map(str, [BIN, *args])), command[-80:]
