"""The documents cannot drift from the program. Every relative
link in the READMEs and docs names an existing file and, with #anchor, a
heading there (GitHub's slug rule), and every section of the detail
documents is one click from README; README stays a front door (at most
400 lines); every option a document shows exists in the --help of refrender,
its subcommands or a script, and every script tool answers --help; every
file README names exists, and its Layout places every source file and
script; tests/README.md maps every test file and says where each source
under src/ is tested; every `make` target named exists; the set-up commands are the ones CI and `make demo` run; and the
other commands README shows are run here: the rendering example, the scene
example, and the researcher's workflow end to end (at a tiny size: the
options appended last override README's); scripts/README.md's export
example runs; and the commands reference_images/README.md shows are those
in the references' own headers."""
import json
import os
import re
import shlex
import shutil
import subprocess

import pytest

from conftest import BIN, ROOT, run

DOCS = ["README.md", "scenes/README.md", "scripts/README.md", "src/EXACT.md", "src/bench/BENCH.md",
        "tests/README.md", "reference_images/README.md", "src/GAUSSIANS.md", "src/TRAJECTORIES.md", "src/SPLAT.md"]
LINK = re.compile(r"\[[^\]]*\]\(([^)\s]+)\)")


def slug(heading):
    """GitHub's anchor for a heading: lower case, punctuation dropped but
    hyphens and underscores, spaces to hyphens."""
    text = heading.lstrip("#").strip().lower()
    return re.sub(r"[^\w\- ]", "", text).replace(" ", "-")


def anchors(path):
    return {slug(line) for line in path.read_text().splitlines() if line.startswith("#")}


@pytest.mark.parametrize("doc", DOCS)
def test_every_relative_link_names_a_file_and_heading(doc):
    path = ROOT / doc
    broken = []
    for target in LINK.findall(path.read_text()):
        if re.match(r"[a-z]+:", target):
            continue  # an absolute URL
        file, _, anchor = target.partition("#")
        dest = (path.parent / file).resolve() if file else path
        if not dest.exists():
            broken.append(f"{target}: no such file")
        elif anchor and dest.suffix == ".md" and anchor not in anchors(dest):
            broken.append(f"{target}: no heading with that anchor")
    assert not broken, f"{doc}: {broken}"


def test_slug_rule_on_known_headings():
    assert slug("## Exact time integration (`--time-integration exact`)") == \
        "exact-time-integration---time-integration-exact"
    assert slug("## Comparing images: `scripts/compare.py`") == "comparing-images-scriptscomparepy"


def test_readme_is_a_front_door():
    assert len((ROOT / "README.md").read_text().splitlines()) <= 400


def help_text():
    texts = [run(["--help"]).stdout]
    for sub in ["merge", "gen", "surfels", "export", "splat", "dataset"]:
        texts.append(run([sub, "--help"]).stdout)
    return "\n".join(texts)


# Slurm's own options (sbatch's), which the cluster documents show beside the scripts'
SLURM_OPTIONS = {"--array", "--cpus-per-task", "--time", "--mem", "--dependency", "--open-mode", "--requeue",
                 "--parsable"}


def shell_script_options():
    """The options the shell scripts' header comments (their usage) name."""
    scripts = [p for p in (ROOT / "scripts").iterdir() if p.suffix in (".sh", ".sbatch")]
    comments = [line for p in scripts for line in p.read_text().splitlines() if line.startswith("#")]
    return set(re.findall(r"--[a-z][a-z0-9-]*", "\n".join(comments))) | SLURM_OPTIONS


def test_every_option_shown_in_readme_exists():
    readme = (ROOT / "README.md").read_text()
    known = set(re.findall(r"--[a-z][a-z0-9-]*", help_text())) | shell_script_options()
    shown = set(re.findall(r"(?<![\w-])--[a-z][a-z0-9-]*", readme))
    not_ours = {"--cropwindow", "--crop", "--label", "--maps", "--latex", "--report", "--sshloginfile", "--json",
                "--csv", "--heatmaps", "--mask", "--alpha", "--exposure", "--entry", "--refrender-curves",
                "--cost-unit", "--entries", "--out",
                "--no-build-isolation", "--no-deps"}  # pbrt's, compare.py's, the other scripts' and pip's own
    nframe = subprocess.run(["/usr/bin/python3", str(ROOT / "scripts" / "nframe_average.py"), "--help"],
                            capture_output=True, text=True).stdout
    missing = shown - known - not_ours - set(re.findall(r"--[a-z][a-z0-9-]*", nframe))
    assert not missing, missing


def test_every_script_and_test_readme_names_exists():
    readme = (ROOT / "README.md").read_text()
    named = set(re.findall(r"\b(?:scripts|tests)/[\w.-]+\.(?:py|sh|sbatch|c)\b", readme))
    assert named and not [n for n in named if not (ROOT / n).exists()]


def test_every_file_the_scene_files_name_exists():
    """A scene file's comment that sends the reader to a script or document
    names one that ships."""
    named = {n for scene in (ROOT / "scenes").rglob("*.xml") for n in
             re.findall(r"\b(?:scripts|src|tests|scenes|reference_images)/[\w./-]*\w", scene.read_text())}
    assert named and not sorted(n for n in named if not (ROOT / n).exists())


def test_the_header_lister_the_readme_names_is_installed():
    """README names a command that lists the EXR header's attributes: it is
    one that scripts/install-deps.sh's packages provide (openexr's
    exrheader is not among them; openimageio-tools' iinfo is)."""
    (tool,) = re.findall(r"Attributes \(`(\S+)[^`]*` lists them", (ROOT / "README.md").read_text())
    assert shutil.which(tool), f"README's {tool} is not installed by scripts/install-deps.sh's packages"


def readme_commands(prefix, section=None):
    """The indented code lines of README (of one ## section, if given) that
    start with prefix, with their continuation lines joined and comments
    dropped."""
    text = (ROOT / "README.md").read_text()
    if section:
        text = text.split(f"\n## {section}\n", 1)[1].split("\n## ", 1)[0]
    text = re.sub(r"```.*?```", "", text, flags=re.S)  # fenced blocks are files, not commands
    out, cur = [], ""
    for line in text.splitlines():
        if not line.startswith("    "):
            continue
        text = line.strip()
        if cur:
            cur += " " + text
        elif text.startswith(prefix):
            cur = text
        if cur and not cur.endswith("\\"):
            out.append(cur.split("  #")[0].strip())
            cur = ""
        elif cur:
            cur = cur[:-1]
    return out


def test_the_rendering_example_runs(tmp_path):
    (cmd,) = readme_commands("build/refrender --spp")
    args = [str(tmp_path / a) if a.endswith((".exr", ".png")) else a for a in shlex.split(cmd)[1:]]
    proc = subprocess.run([BIN, *args, "--res", "16x12", "--spp", "1", "--tspp", "4", "--quiet"], cwd=ROOT,
                          capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    assert (tmp_path / "frame.exr").exists() and (tmp_path / "frame.png").exists()


def test_the_researchers_workflow_runs_end_to_end(tmp_path):
    """README's 'Comparing a method': the ground truth, the export, two
    'methods' (refrender itself at other seeds, standing in) and compare.py
    with every output the README promises."""
    (scene := tmp_path / "scenes").mkdir()
    shutil.copytree(ROOT / "scenes", scene, dirs_exist_ok=True, ignore=shutil.ignore_patterns("models"))
    (tmp_path / "build").mkdir()
    (tmp_path / "build" / "refrender").symlink_to(BIN)
    (tmp_path / "scripts").symlink_to(ROOT / "scripts")
    small = ["--res", "48x28", "--spp", "1", "--tspp", "4"]
    # two frames rather than README's four: still a sequence (mean and worst rows), and compare.py's
    # maps (matplotlib figures for each frame, method and window) were most of this test's time
    two = ("--frames 0-3", "--frames 0-1")
    for cmd in readme_commands("mkdir", "Comparing a method") + \
            readme_commands("build/refrender scenes/animated.xml", "Comparing a method") + \
            readme_commands("build/refrender export", "Comparing a method"):
        args = shlex.split(cmd.replace(*two))
        if args[0] == "build/refrender" and args[1] != "export":
            args += small
        proc = subprocess.run(args, cwd=tmp_path, capture_output=True, text=True)
        assert proc.returncode == 0, (cmd, proc.stderr)
    for method, seed in [("ours", "11"), ("theirs", "12")]:
        proc = subprocess.run(["build/refrender", "scenes/animated.xml", "--frames", "0-1", *small, "--seed", seed,
                               "--quiet", "-o", f"{method}/{method}.%04d.exr"], cwd=tmp_path, capture_output=True,
                              text=True)
        assert proc.returncode == 0, proc.stderr
    (cmd,) = readme_commands("scripts/compare.py '", "Comparing a method")
    args = shlex.split(cmd.replace("--crop 90,50,64,48", "--crop 18,10,16,12").replace(*two))
    proc = subprocess.run(["/usr/bin/python3", *args], cwd=tmp_path, capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    assert (tmp_path / "table.tex").exists() and (tmp_path / "report" / "index.html").exists()
    assert any((tmp_path / "figs").iterdir()) and (tmp_path / "animated.json").exists()


def test_tests_readme_maps_every_test_file():
    """tests/README.md is a map from topics to files: it names every test
    file (a new one must be placed on the map), and every file it names
    exists (a renamed one cannot linger)."""
    text = (ROOT / "tests" / "README.md").read_text()
    named = set(re.findall(r"`((?:tests/)?[\w./-]+\.(?:py|c))`", text))
    named = {n for n in named if not n.startswith("src/")}  # the sources' table: the next test
    missing = [n for n in named if not any((ROOT / d / n.removeprefix(f"{d}/")).exists() for d in ("tests", "scripts"))]
    assert not missing, missing
    files = {p.name for p in (ROOT / "tests").glob("test_*.[cp]*") if p.suffix in (".c", ".py")}
    unmapped = sorted(files - {n.rsplit("/", 1)[-1] for n in named})
    assert not unmapped, unmapped



def compare_modules():
    """The scripts/README.md row naming the modules compare.py is made of
    (imported, not run)."""
    (row,) = [line for line in (ROOT / "scripts" / "README.md").read_text().splitlines()
              if line.startswith("|") and "the modules `compare.py` is made of" in line]
    return set(re.findall(r"`([\w-]+\.py)`", row.split("|")[1]))


def source_test_table(text):
    """tests/README.md's "Where each source is tested" rows as {source: [test files]}."""
    assert "## Where each source is tested" in text, "tests/README.md has no 'Where each source is tested'"
    section = text.split("## Where each source is tested", 1)[1].split("\n## ", 1)[0]
    rows = {}
    for line in section.splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) == 2 and cells[0].startswith("`src/"):
            rows[cells[0].strip("`")] = re.findall(r"`([\w./-]+)`", cells[1])
    return rows


def test_tests_readme_says_where_every_source_is_tested():
    """tests/ mirrors src/ through a table: every C source under src/ has a row in tests/README.md
    naming at least one test file, every file a row names exists in tests/, and no row names a
    source that is gone."""
    rows = source_test_table((ROOT / "tests" / "README.md").read_text())
    sources = {str(p.relative_to(ROOT)) for p in (ROOT / "src").rglob("*") if p.suffix in (".c", ".cpp")}
    assert sorted(sources - set(rows)) == [], "sources without a row"
    assert sorted(set(rows) - sources) == [], "rows for sources that do not exist"
    bad = {s: t for s, t in rows.items() if not t or not all((ROOT / "tests" / f).is_file() for f in t)}
    assert not bad, f"rows naming no test file, or one that does not exist: {bad}"


def test_source_table_parser_sees_a_missing_row():
    """The check above can fail: a table without a source's row, or naming a test file that does
    not exist, is seen."""
    text = "## Where each source is tested\n| source | tested in |\n| --- | --- |\n" \
           "| `src/core/common.c` | `test_common.c` |\n| `src/core/x.c` | `test_nonexistent.c` |\n\n## Next\n" \
           "| `src/core/camera.c` | `test_camera.c` |\n"
    rows = source_test_table(text)
    assert rows == {"src/core/common.c": ["test_common.c"], "src/core/x.c": ["test_nonexistent.c"]}
    assert not (ROOT / "tests" / "test_nonexistent.c").exists()


@pytest.mark.parametrize("script", sorted({p.name for p in (ROOT / "scripts").glob("*.py")} - compare_modules()))
def test_every_script_answers_help(script):
    """scripts/README.md promises it: each tool's own manual is its --help
    (the modules compare.py imports, named there, are not tools)."""
    proc = subprocess.run(["/usr/bin/python3", str(ROOT / "scripts" / script), "--help"], capture_output=True,
                          text=True, timeout=120)
    assert proc.returncode == 0 and "usage" in proc.stdout.lower(), (proc.stdout, proc.stderr)


def test_the_scene_example_renders(tmp_path):
    """README's scene example, saved where README says, with the model made
    by the command README shows, renders (at a tiny size)."""
    readme = (ROOT / "README.md").read_text()
    xml = readme.split("\n## Scenes\n", 1)[1].split("```xml\n", 1)[1].split("```", 1)[0]
    make_model, render = readme_commands("", "Scenes")
    (tmp_path / "build").mkdir()
    (tmp_path / "build" / "refrender").symlink_to(BIN)
    proc = subprocess.run(make_model + " --count 2000", shell=True, cwd=tmp_path, capture_output=True, text=True)
    assert proc.returncode == 0, (make_model, proc.stderr)
    (tmp_path / "my" / "scene.xml").write_text(xml)
    args = shlex.split(render) + ["--res", "32x32", "--spp", "1", "--tspp", "4", "--quiet"]
    proc = subprocess.run(args, cwd=tmp_path, capture_output=True, text=True)
    assert proc.returncode == 0, (render, proc.stderr)
    assert (tmp_path / "my" / "scene.exr").exists() and (tmp_path / "my" / "scene.png").exists()


def test_setup_commands_are_what_ci_and_make_run():
    """README's set-up is two commands: the first is CI's first step and
    builds and renders the demo, the second is exactly what CI runs."""
    cmds = readme_commands("", "Set-up (fresh Debian 12)")
    assert cmds == ["scripts/install-deps.sh && make demo", "make test"], cmds
    ci = [line.strip() for line in (ROOT / ".ci" / "run").read_text().splitlines()]
    assert "scripts/install-deps.sh" in ci and "make test" in ci
    makefile = (ROOT / "Makefile").read_text()
    demo = makefile.split("\ndemo:", 1)[1].split("\n\n", 1)[0]
    assert "deps" in demo.splitlines()[0] and "scenes/default.xml -o out/demo.exr --preview out/demo.png" in demo


def test_every_make_target_the_documents_name_exists():
    targets = set(re.findall(r"^([\w-]+)\s*:", (ROOT / "Makefile").read_text(), re.M))
    named = set()
    for doc in DOCS:
        named |= set(re.findall(r"`make (?:[A-Z_]+=\S+ )*([a-z][\w-]*)", (ROOT / doc).read_text()))
    assert named and not named - targets, named - targets


def layout_folders(layout):
    """Layout's src/ block: each folder's text (its line and the indented
    lines continuing it)."""
    folders, current = {}, None
    for line in layout.splitlines():
        m = re.match(r"    (src/\w+/)\s+(.*)", line)
        if m:
            current = m.group(1)
            folders[current] = m.group(2)
        elif current and re.match(r"\s{8,}\S", line) and not line.strip().startswith(("tests/", "scripts/")):
            folders[current] += " " + line.strip()
        else:
            current = None
    return folders


def test_layout_places_every_source_file_and_script():
    """README's Layout names every library and command file (a new file
    must be placed: a source file by its name in its folder's line) and
    every file and folder it names exists; scripts/README.md names every
    script."""
    layout = (ROOT / "README.md").read_text().split("\n## Layout\n", 1)[1].split("\n## ", 1)[0]
    named = set(re.findall(r"\b((?:src|tests|scripts)/[\w./*-]*\w/?)", layout))
    assert not [n for n in named if not list(ROOT.glob(n.rstrip("/")))]
    folders = layout_folders(layout)

    def placed(src):  # its name, or a prefix* covering it, in its folder's text
        words = re.findall(r"\w+\*?", folders.get(f"src/{src.parts[1]}/", ""))
        return any(w == src.stem or (w.endswith("*") and src.stem.startswith(w[:-1])) for w in words)
    sources = [p.relative_to(ROOT) for pat in ("src/*/*.c", "src/*/*.cpp") for p in ROOT.glob(pat)]
    assert not sorted(s.as_posix() for s in sources if not placed(s))
    # the scripts are placed in their own manual (README's Layout points there)
    manual = (ROOT / "scripts" / "README.md").read_text()
    scripts = [p.name for p in ROOT.glob("scripts/*") if p.is_file() and p.suffix != ".md"]
    unplaced = [f for f in scripts if not re.search(rf"`(?:scripts/)?{re.escape(f)}`", manual)]
    assert not unplaced, unplaced


def test_every_detail_section_is_one_click_from_readme():
    """Each document the details moved to, and each of its sections, is
    linked from README."""
    readme = (ROOT / "README.md").read_text()
    links = set(LINK.findall(readme))
    unlinked = []
    for doc in DOCS[1:]:
        if doc not in {link.partition("#")[0] for link in links}:
            unlinked.append(doc)
        for line in (ROOT / doc).read_text().splitlines():
            if line.startswith("## ") or line.startswith("### "):
                if f"{doc}#{slug(line)}" not in links:
                    unlinked.append(f"{doc}#{slug(line)}")
    assert not unlinked, unlinked


# Runs each script as `python3 SCRIPT --help` would (runpy, as __main__, with that argv) in one Python
# process: every script imports numpy and OpenImageIO, which one process then loads once.
_HELP_DRIVER = """
import contextlib, io, runpy, sys
sys.path.insert(0, sys.argv[1])
for script in sys.argv[2:]:
    sys.argv = [script, "--help"]
    out = io.StringIO()
    try:
        with contextlib.redirect_stdout(out):
            runpy.run_path(script, run_name="__main__")
    except SystemExit as stop:
        assert stop.code in (0, None), (script, stop.code)
    print(out.getvalue() + "\\0", end="")
"""


def scripts_help():
    """Every tool's --help text (scripts/*.py but the modules compare.py is made of)."""
    scripts = [str(ROOT / "scripts" / name)
               for name in sorted({p.name for p in (ROOT / "scripts").glob("*.py")} - compare_modules())]
    proc = subprocess.run(["/usr/bin/python3", "-c", _HELP_DRIVER, str(ROOT / "scripts"), *scripts],
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    texts = proc.stdout.split("\0")[:-1]
    assert len(texts) == len(scripts) and all("usage" in t.lower() for t in texts), proc.stdout
    return texts


def test_every_option_the_detail_documents_show_exists():
    """A refrender option in the scene, script, speed and exact-time documents
    exists in refrender's --help or in a script's."""
    known = set(re.findall(r"--[a-z][a-z0-9-]*", help_text())) | shell_script_options()
    known |= set(re.findall(r"--[a-z][a-z0-9-]*", "\n".join(scripts_help())))
    missing = {}
    for doc in DOCS[1:]:
        shown = set(re.findall(r"(?<![\w-])--[a-z][a-z0-9-]*", (ROOT / doc).read_text()))
        if shown - known - {"--cropwindow", "--sshloginfile", "--no-recommends"}:
            missing[doc] = shown - known
    assert not missing, missing


def test_reference_commands_are_the_ones_in_their_headers():
    """reference_images/README.md's table shows, for each reference, the
    command written into that EXR's header (refrender:command)."""
    import OpenImageIO as oiio
    rows = re.findall(r"^\| `scenes/(\w+)\.xml` \| `([^`]+)` \|", (ROOT / "reference_images" / "README.md").read_text(),
                      re.M)
    assert len(rows) >= 10
    for name, command in rows:
        inp = oiio.ImageInput.open(str(ROOT / "reference_images" / f"{name}.exr"))
        assert inp, name
        header = inp.spec().getattribute("refrender:command")
        inp.close()
        assert header == command, name


def test_the_export_example_in_scripts_readme_runs(tmp_path):
    (cmd,) = [line.strip() for line in (ROOT / "scripts" / "README.md").read_text().splitlines()
              if line.startswith("    build/refrender export")]
    args = shlex.split(cmd)
    args[args.index("-o") + 1] = str(tmp_path / "animated.json")
    proc = subprocess.run([BIN, *args[1:]], cwd=ROOT, capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    import json
    frames = json.loads((tmp_path / "animated.json").read_text())["frames"]
    assert len(frames) == 24 and all(len(f["times"]) == 10 for f in frames)


def test_the_gaussian_splatting_workflow_runs(tmp_path):
    """README's 'Gaussian splatting': its scene example parses and renders beside
    the toy cameras.json and model of scenes/examples/ it names (that it is
    that example: tests/test_examples.py), and its commands run at a tiny
    size, with the 2DGS bunny made as 'make scenes' makes it."""
    readme = (ROOT / "README.md").read_text().split("\n## Gaussian splatting\n", 1)[1].split("\n## ", 1)[0]
    xml = readme.split("```xml\n", 1)[1].split("```", 1)[0]
    for name in ("cameras.json", "sphere_3dgs.ply"):
        shutil.copy(ROOT / "scenes" / "examples" / name, tmp_path)
    (tmp_path / "scene.xml").write_text(xml)
    proc = subprocess.run([BIN, "scene.xml", "--spp", "1", "--tspp", "2", "--quiet", "-o", "x.exr"], cwd=tmp_path,
                          capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    fetch = [line for line in (ROOT / "scripts" / "fetch-models.sh").read_text().split("\n\n")[-1].splitlines()]
    assert "make scenes" in readme and "bunny_2dgs" in "\n".join(fetch)
    (tmp_path / "scenes" / "models").mkdir(parents=True)
    shutil.copy(ROOT / "scenes" / "gaussians.xml", tmp_path / "scenes")
    proc = subprocess.run([BIN, "surfels", "/usr/share/glmark2/models/bunny.obj", "--fit", "1", "--gaussians", "2dgs",
                           "--sh-degree", "3", "-o", tmp_path / "scenes" / "models" / "bunny_2dgs.ply"],
                          capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    (tmp_path / "build").mkdir()
    (tmp_path / "build" / "refrender").symlink_to(BIN)
    (tmp_path / "scripts").symlink_to(ROOT / "scripts")
    # 16x16 pixels each hold hundreds of the bunny's Gaussians: few samples (tspp 2, batches 2) keep it quick
    tiny = {"128x128": "16x16", "256": "8", "128": "2", "8": "2", "16": "4", "10,16,51": "2,3",
            "midpoint,deblur-nerf,bad-gaussians,3dgs-deblur": "deblur-nerf"}  # its 10 frames, not 47
    for cmd in readme_commands("build/refrender scenes/gaussians.xml", "Gaussian splatting") + \
            readme_commands("scripts/nframe_average.py", "Gaussian splatting"):
        args = [tiny.get(a, a) for a in shlex.split(cmd)]
        if args[0].startswith("scripts/"):
            args = ["/usr/bin/python3", *args, "--", "--res", "16x16", "--spp", "1"]
        proc = subprocess.run(args, cwd=tmp_path, capture_output=True, text=True,
                              env={**os.environ, "REFRENDER": str(tmp_path / "build" / "refrender")})
        assert proc.returncode == 0, (cmd, proc.stderr)
    assert (tmp_path / "f.png").exists() and "deblur-nerf" in proc.stdout, proc.stdout


def test_no_script_puts_its_own_folder_on_the_path_again():
    # Python puts a script's own folder first on sys.path: a script inserting
    # it again only repeats it (inserting ../python, the package's folder, is
    # how a script imports the refrender package's modules from a clone)
    inserting = {p.name for p in (ROOT / "scripts").glob("*.py") for line in p.read_text().splitlines()
                 if "sys.path.insert" in line and 'os.pardir, "python")' not in line}
    assert not inserting, inserting


def test_licence_and_citation_are_there_and_named():
    """LICENSE is the Apache License 2.0 word for word (Debian's copy of the
    standard text, when installed, is the independent source), CITATION.cff
    is Citation File Format 1.2.0 with its required keys, and README names
    both."""
    yaml = pytest.importorskip("yaml")
    text = (ROOT / "LICENSE").read_text()
    debian = "/usr/share/common-licenses/Apache-2.0"
    if os.path.exists(debian):
        assert text == open(debian).read()
    assert "Apache License" in text and "Version 2.0, January 2004" in text and "END OF TERMS AND CONDITIONS" in text
    cff = yaml.safe_load((ROOT / "CITATION.cff").read_text())
    assert cff["cff-version"] == "1.2.0" and cff["license"] == "Apache-2.0"
    assert all(cff.get(k) for k in ("message", "title", "authors"))
    readme = (ROOT / "README.md").read_text()
    assert "[LICENSE](LICENSE)" in readme and "[CITATION.cff](CITATION.cff)" in readme


def test_fetch_models_offline_stops_with_one_line(tmp_path):
    """`make scenes` (the first step of `make test`) without a network: the
    download of libcgal-demo fails (a stand-in apt-get that fails as an
    offline one does), and the script stops with a line naming the package,
    the models that need it and what to do, after converting what needs no
    download (the glmark2 bunny). README says so."""
    if not os.path.exists("/usr/share/glmark2/models/bunny.obj"):
        pytest.skip("glmark2-data not installed")
    (tmp_path / "scripts").mkdir()
    shutil.copy(ROOT / "scripts" / "fetch-models.sh", tmp_path / "scripts")
    fake = tmp_path / "bin"
    fake.mkdir()
    for name, body in (("apt-get", "echo 'E: Failed to fetch (offline)' >&2; exit 100"), ("sudo", 'exec "$@"')):
        (fake / name).write_text(f"#!/bin/sh\n{body}\n")
        (fake / name).chmod(0o755)
    proc = subprocess.run(["sh", str(tmp_path / "scripts" / "fetch-models.sh")], capture_output=True, text=True,
                          env={**os.environ, "PATH": f"{fake}:{os.environ['PATH']}", "REFRENDER": BIN}, timeout=120)
    assert proc.returncode == 1, proc.stderr
    last = proc.stderr.strip().splitlines()[-1]
    assert last.startswith("fetch-models.sh: cannot download Debian's libcgal-demo (offline?") and "kitten" in last
    assert (tmp_path / "scenes" / "models" / "bunny.ply").stat().st_size > 0
    assert "offline it stops there with one line" in (ROOT / "README.md").read_text()
