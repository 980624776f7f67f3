"""--checkpoint-every 0 means what render.h says (a
checkpoint only when interrupted), not the 60 s it silently became; the
default stays 60 s. Periodic checkpoints are seen being written while a
render runs with a short period, and none with 0."""
import signal
import subprocess
import time

from conftest import BIN, wait_for_handlers

SCENE = """<scene><camera position="0 0 5" lookat="0 0 0" width="64" height="64"/>
<object><pointModel generate="sphere" count="4000" radius="1"/>
<animation><rotation axis="0 1 0" center="0 0 0" degrees_per_unit_time="90"/></animation></object></scene>"""


def start(tmp_path, every):
    scene = tmp_path / "s.xml"
    scene.write_text(SCENE)
    ckpt = tmp_path / f"c{every}.exr"
    args = [BIN, str(scene), "--spp", "16", "--tspp", "64", "--batches", "64", "--threads", "1",
            "-o", str(tmp_path / "o.exr"), "--checkpoint", str(ckpt)]
    if every is not None:
        args += ["--checkpoint-every", str(every)]
    return subprocess.Popen(args, stderr=subprocess.PIPE, text=True), ckpt


def stop(proc):
    proc.send_signal(signal.SIGINT)
    return proc.communicate(timeout=60)[1]


def test_zero_means_only_when_interrupted(tmp_path):
    proc, ckpt = start(tmp_path, 0)
    wait_for_handlers(proc)
    time.sleep(1.5)
    assert proc.poll() is None, "the render must outlast the wait"
    assert not ckpt.exists()  # no periodic checkpoint
    err = stop(proc)
    assert "only when interrupted" in err and proc.returncode == 130
    assert ckpt.exists()  # the one written when interrupted


def test_a_short_period_writes_while_rendering_and_60_is_the_default(tmp_path):
    proc, ckpt = start(tmp_path, 0.2)
    deadline = time.time() + 20
    while not ckpt.exists() and time.time() < deadline and proc.poll() is None:
        time.sleep(0.05)
    assert ckpt.exists() and proc.poll() is None  # written while still rendering
    stop(proc)
    proc, _ = start(tmp_path, None)
    wait_for_handlers(proc)  # past start-up, where the interrupt handler is installed
    time.sleep(0.5)
    assert "every 60 s and when interrupted" in stop(proc)
