"""scripts/cost_error.py: error against cost for any method's
images, with hand-computed RMSEs, refrender's curves drawn from a
convergence CSV, and clear errors for bad entries."""
import csv
import subprocess

import numpy as np

from conftest import ROOT
from test_compare import write_image

SCRIPT = ROOT / "scripts" / "cost_error.py"


def run_script(*args):
    return subprocess.run(["/usr/bin/python3", str(SCRIPT), *map(str, args)], capture_output=True, text=True)


def test_rmse_against_cost_for_any_method(tmp_path):
    ref = write_image(tmp_path / "ref.exr", np.full((16, 16, 3), 0.5, np.float32))
    imgs = [write_image(tmp_path / f"m{k}.exr", np.full((16, 16, 3), 0.5 + off, np.float32))
            for k, off in enumerate([0.2, 0.1, 0.05])]
    curves = tmp_path / "convergence.csv"
    with open(curves, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["sampler", "samples", "spp", "tspp", "seconds", "rmse"])
        w.writerows([["sobol", 16, 4, 4, 0.5, 0.1], ["sobol", 64, 4, 16, 2.0, 0.04]])
    out = tmp_path / "out"
    proc = run_script(ref, *sum([["--entry", f"ours,{p},{c}"] for p, c in zip(imgs, [1, 2, 4])], []),
                      "--refrender-curves", curves, "--out", out)
    assert proc.returncode == 0, proc.stderr
    rows = list(csv.DictReader(open(out / "cost_error.csv")))
    assert [round(float(r["rmse"]), 6) for r in rows] == [0.2, 0.1, 0.05]
    assert [float(r["seconds"]) for r in rows] == [1, 2, 4]
    assert (out / "cost_error.png").stat().st_size > 1000


def test_bad_entries_are_named(tmp_path):
    ref = write_image(tmp_path / "ref.exr", np.zeros((16, 16, 3), np.float32))
    bad = run_script(ref, "--entry", f"x,{ref},-3", "--out", tmp_path / "o")
    assert bad.returncode == 2 and "cost must be a positive number" in bad.stderr
    none = run_script(ref, "--out", tmp_path / "o")
    assert none.returncode == 2 and "no entries" in none.stderr
    assert run_script("--help").returncode == 0


def test_refrender_curves_are_told_apart():
    """The three samplers' reference curves differ in line style and
    marker (not only in a grey a reader cannot tell apart), and the legend
    names each."""
    import cost_error
    drawn = []
    curves = {f"refrender {s}": [(16, 0.1), (64, 0.05)] for s in ("thesis", "jittered3d", "sobol")}
    cost_error.plot([("ours", "a.exr", 1.0, 0.2, 0.1), ("ours", "b.exr", 2.0, 0.1, 0.05)], curves, "samples",
                    drawn.append)
    (fig,) = drawn
    rmse_axis = fig.axes[0]
    lines = {line.get_label(): line for line in rmse_axis.get_lines()}
    styles = {(lines[name].get_linestyle(), lines[name].get_marker()) for name in curves}
    assert len(styles) == len(curves) and ("-", "o") not in styles  # apart from each other and from the methods'
    legend = [t.get_text() for t in rmse_axis.get_legend().get_texts()]
    assert set(curves) <= set(legend)
