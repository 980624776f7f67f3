"""scripts/time_to_error.py (make bench): a scene exact time refuses (past
its candidate or evaluation bounds, src/EXACT.md) is reported as refused in
the table, not the end of the benchmark; the large suite scene is one."""
import importlib
import os

import pytest

from conftest import BIN

# 40000 splats overlapping so that one pixel's ray meets more than the 32,768 candidates exact time
# gathers at most (src/EXACT.md, Bounds): refused at once, where a scene past the 5e7-evaluation
# bound spent 5 CPU seconds before its refusal; the script treats both refusals alike
OVERLAPPING = """<scene><camera position="0 0 5" lookat="0 0 0" width="2" height="2"/>
<object><pointModel generate="plane" count="40000" radius="1" overlap="1000"/>
<animation><rotation axis="0 1 0" center="0 0 0" degrees_per_unit_time="30"/></animation></object></scene>"""


@pytest.fixture
def tte(monkeypatch):
    monkeypatch.setenv("REFRENDER", BIN)
    import time_to_error
    return importlib.reload(time_to_error)


def test_a_refused_exact_render_is_a_measurement(tmp_path, tte):
    scene = tmp_path / "o.xml"
    scene.write_text(OVERLAPPING)
    out = str(tmp_path / "o.exr")
    assert tte.render(str(scene), out, ["--time-integration", "exact", "--spp", 1], "2x2", 1) is None
    assert tte.render(str(scene), out, ["--spp", 1, "--tspp", 2], "2x2", 1) > 0
    assert tte.time_to([], 0.01) == (None, None) and tte.cell(None, None) == "refused"
    assert os.path.exists(out)
