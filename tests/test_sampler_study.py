"""scripts/sampler_study.py (make bench-samplers): the tables it prints follow from the rows by
arithmetic done here by hand: errors that fall exactly as N^-1 fit a rate of -1 and reach 1 and
0.1 levels at the samples the line says; each cell names its ratio to the best sampler at that
count; CPU seconds linear in the samples give a level's 2-core seconds from the same line. And
the error of a render is measured from two seeds, not from a reference or its own error bars."""
import importlib
import math
import subprocess
from pathlib import Path

import pytest

from conftest import BIN


@pytest.fixture
def study(monkeypatch):
    monkeypatch.setenv("REFRENDER", BIN)
    import sampler_study
    return importlib.reload(sampler_study)


def rows_falling_as_one_over_n(sampler, scale):
    return [{"view": "v", "sampler": sampler, "samples": n, "seconds": n / 100, "error_levels": scale * 64 / n}
            for n in (16, 64, 256)]


def test_the_convergence_table_fits_the_rate_and_the_samples_to_each_level(study):
    table = study.convergence_table(rows_falling_as_one_over_n("a", 1.0) + rows_falling_as_one_over_n("b", 2.0))
    a = next(l for l in table.splitlines() if l.startswith("| v | a |"))
    b = next(l for l in table.splitlines() if l.startswith("| v | b |"))
    assert "| -1.00 |" in a and "| 64 / 640 |" in a  # error 64 / N: 1 level at 64, 0.1 at 640
    assert "0.25 (1.00x)" in a and "0.5 (2.00x)" in b and "| 128 / 1.28e+03 |" in b


def test_the_time_table_reaches_each_level_on_the_fitted_lines(study):
    rows = [{"samples": n, "seconds": 0, "cpu_seconds": 10 + 0.5 * n, "error_levels": 32 / n} for n in (32, 128, 512)]
    table = study.time_table(rows)
    # 1 level at 32 samples: (10 + 16) / 2 = 13 s; 0.1 at 320: (10 + 160) / 2 = 85 s; 0.01 at 3200: 805 s
    assert "| 1 | 32 | 13 |" in table and "| 0.1 | 320 | 85 |" in table and "| 0.01 | 3200 | 805 |" in table


def test_a_renders_error_is_measured_from_two_seeds(tmp_path, study):
    scene = tmp_path / "s.xml"
    scene.write_text('<scene><camera position="0 0 5" lookat="0 0 0" width="8" height="8"/>'
                     '<object><pointModel><splat center="0 0 0" normal="0 0 1" radius="1" color="1 1 1"/></pointModel>'
                     '<material shading="unlit"/><animation><linear velocity="1 0 0"/></animation></object></scene>')
    err, seconds, header = study.pair_error(str(scene), str(tmp_path / "o.exr"), ["--spp", 1, "--tspp", 4])
    assert err > 0 and seconds > 0 and header["refrender:sampler"] == "sobol"
    same, _, _ = study.pair_error(str(scene), str(tmp_path / "o.exr"), ["--spp", 1, "--tspp", 4, "--time", 0.5, "--pixel-filter", "point"])
    assert same == 0  # one instant at the pixel centres: both seeds give the same image
    assert not math.isnan(err)


SCRIPT = str(Path(__file__).resolve().parent.parent / "scripts" / "sampler_study.py")
HEADER = "view,sampler,samples,spp,tspp,seconds,error_levels\n"


def study_run(*args):
    return subprocess.run(["/usr/bin/python3", SCRIPT, *map(str, args)], capture_output=True, text=True, timeout=60)


@pytest.mark.parametrize("text, says", [
    ("", "empty"), (HEADER, "no rows, only a header"),
    ("view,sampler,samples,seconds\nv,a,16,1\n", "no column error_levels"),
    (HEADER + "v,a,0,1,1,1,0.5\nv,a,16,1,16,1,0.2\n", ":2: samples '0' is not a positive integer"),
    (HEADER + "v,a,16,1,16,1,abc\n", ":2: error_levels 'abc' is not a finite number")])
def test_a_bad_csv_is_one_line_naming_it(tmp_path, text, says):
    """Before: IndexError, KeyError, a math domain error, each a traceback."""
    path = tmp_path / "c.csv"
    path.write_text(text)
    proc = study_run("table", path)
    assert proc.returncode == 1 and "Traceback" not in proc.stderr, proc.stderr
    assert proc.stderr.strip().splitlines() == [proc.stderr.strip()] and f"{path}" in proc.stderr, proc.stderr
    assert says in proc.stderr, proc.stderr


@pytest.mark.parametrize("args", [("convergence", "--counts", "abc"), ("convergence", "--counts", "0"),
                                  ("convergence", "--views", ","), ("convergence", "--samplers", ","),
                                  ("time-to-error", "--counts", "abc"), ("time-to-error", "--counts", "64")])
def test_bad_options_are_usage_errors(tmp_path, args):
    proc = study_run(*args, "--out", tmp_path / "o")
    assert proc.returncode == 2 and "Traceback" not in proc.stderr and "error: " in proc.stderr, proc.stderr
    assert not (tmp_path / "o").exists()


def test_a_row_given_again_replaces_the_earlier_one_in_the_best_too(tmp_path):
    """a.csv and b.csv both measure v/sobol/16; the later (b's 0.5) is the row
    kept, so the best at 16 is thesis's 0.4 (not the dropped 0.2): sobol is
    0.5 / 0.4 = 1.25x, thesis 1.00x. Before: sobol 2.50x, thesis 2.00x."""
    a, b = tmp_path / "a.csv", tmp_path / "b.csv"
    a.write_text(HEADER + "v,sobol,16,1,16,1,0.2\n")
    b.write_text(HEADER + "v,sobol,16,1,16,1,0.5\nv,sobol,64,1,64,1,0.25\nv,thesis,16,1,16,1,0.4\n")
    proc = study_run("table", a, b)
    assert proc.returncode == 0, proc.stderr
    sobol = next(l for l in proc.stdout.splitlines() if l.startswith("| v | sobol |"))
    thesis = next(l for l in proc.stdout.splitlines() if l.startswith("| v | thesis |"))
    assert "| 0.5 (1.25x) | 0.25 (1.00x) |" in sobol and "| 0.4 (1.00x) |" in thesis, proc.stdout
    assert "v sobol 16 given again" in proc.stderr
