"""refrender.render: the render command run in-process (librefrender.so),
its final image returned as numpy arrays and its header as a dict, the very
values `refrender ... -o out.exr` writes into the EXR."""
import contextlib
import ctypes
import signal
import threading
import time
from typing import NamedTuple, Optional

import numpy as np

from . import _library

# EXR attribute types as refrender_result_attr_type numbers them (refrender_api.h)
_TEXT, _INT, _DOUBLE, _MATRIX = 0, 1, 2, 3
_LOCK = threading.Lock()  # one render at a time: the command's state is the process's


class RenderError(RuntimeError):
    """The render failed: str(e) is the line the command line prints after
    "refrender: " (the file and line of a bad scene, say); e.status is its
    exit status (1 bad input or render error, 2 usage error)."""

    def __init__(self, message, status):
        super().__init__(message)
        self.status = status


class Render(NamedTuple):
    """A render's final image: rgba (H x W x 4 float32, R G B A), stderr and
    variance (H x W x 4, of R G B A; None unless a pixel has 2 or more
    batches), samples (H x W), the header (attribute name -> str, int, float,
    or a 4 x 4 float32 matrix for worldToCamera and its kin) and window: the
    data window (x0, y0, width, height) inside the full image (full_width,
    full_height), as the EXR's (a crop window's pixels with crop_window)."""
    rgba: np.ndarray
    stderr: Optional[np.ndarray]
    variance: Optional[np.ndarray]
    samples: np.ndarray
    header: dict
    window: dict


def _option_words(name, value):
    """One keyword as the command line's words: spp=4 -> --spp=4, True -> the
    bare flag, False or None -> nothing; a tuple or list joins with ','
    (shutter=(0, 1), crop_window=...) except res=(W, H) -> WxH."""
    flag = "--" + name.replace("_", "-")
    if value is None or value is False:
        return []
    if value is True:
        return [flag]
    if isinstance(value, (tuple, list)):
        value = ("x" if name == "res" else ",").join(repr(v) if isinstance(v, float) else str(v) for v in value)
    elif isinstance(value, float):
        value = repr(value)  # the shortest text that reads back as the same double
    return [f"{flag}={value}"]


def command_words(scene, params=None, **options):
    """The command line render() runs (without the program name)."""
    words = []
    for name, value in options.items():
        words += _option_words(name, value)
    for name, value in (params or {}).items():
        words += ["-D", f"{name}={value}"]
    return words + ["--", str(scene)]


def _planes(lib, result, height, width):
    planes = {}
    for i in range(lib.refrender_result_channels(result)):
        name = lib.refrender_result_channel_name(result, i).decode()
        data = np.ctypeslib.as_array(lib.refrender_result_channel(result, i), shape=(height, width))
        planes[name] = data.copy()
    return planes


def _header(lib, result):
    header, numbers = {}, (ctypes.c_double * 16)()
    for i in range(lib.refrender_result_attrs(result)):
        key = lib.refrender_result_attr_key(result, i).decode()
        kind = lib.refrender_result_attr_type(result, i)
        n = lib.refrender_result_attr_numbers(result, i, numbers)
        if kind == _INT:
            header[key] = int(numbers[0])
        elif kind == _DOUBLE:
            header[key] = float(numbers[0])
        elif kind == _MATRIX and n == 16:
            header[key] = np.array(numbers[:16], dtype=np.float32).reshape(4, 4)
        else:
            header[key] = lib.refrender_result_attr_text(result, i).decode()
    return header


def _stack(planes, prefix):
    names = [prefix + c for c in "RGBA"]
    return np.stack([planes[n] for n in names], axis=-1) if all(n in planes for n in names) else None


def _result(lib, result):
    window = (ctypes.c_int * 6)()
    lib.refrender_result_window(result, window)
    full_w, full_h, x0, y0, w, h = window
    planes = _planes(lib, result, h, w)
    return Render(rgba=_stack(planes, ""), stderr=_stack(planes, "stderr."), variance=_stack(planes, "variance."),
                  samples=planes["samples"], header=_header(lib, result),
                  window={"x0": x0, "y0": y0, "width": w, "height": h, "full_width": full_w, "full_height": full_h})


def _wait(ended, finished):
    """Waits for the render's end; a Ctrl-C meanwhile changes nothing (it is stopping)."""
    while not ended:
        try:
            finished.acquire(timeout=0.05)
        except KeyboardInterrupt:
            continue


def _began(worker):
    """Whether the worker thread runs (its end will come): an exception
    raised inside Thread.start after the thread was created leaves it
    running; its bootstrap sets its ident at once."""
    deadline = time.monotonic() + 1.0
    while worker.ident is None and time.monotonic() < deadline:
        time.sleep(0.001)
    return worker.ident is not None


@contextlib.contextmanager
def _sigint_sets(interrupt):
    """While the render runs, Ctrl-C sets the C's interrupt flag instead of
    raising KeyboardInterrupt wherever this thread happens to be: raised
    inside Thread.start (whose Event wait it can interrupt after the worker
    has begun), it left the render running unwatched while the caller went
    on, and the process hung at exit (seen in a loaded test run). render()
    raises KeyboardInterrupt itself once the render has stopped (status 130).
    Only the main thread receives signals in Python, and a handler the
    caller installed is theirs: both are left alone."""
    if (threading.current_thread() is not threading.main_thread()
            or signal.getsignal(signal.SIGINT) is not signal.default_int_handler):
        yield
        return

    def stop(signum, frame):
        interrupt.value = 1
    previous = signal.signal(signal.SIGINT, stop)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


def _run(lib, words):
    """Runs the render in a thread of its own while this one waits, so that
    Ctrl-C stops it: the C watches the flag Ctrl-C sets (_sigint_sets), as
    the command line watches SIGINT, and stops within the batch it is in.
    Its end is a list the worker appends to before it releases a plain lock,
    which wakes the wait at once: not Thread.join (a join interrupted by
    KeyboardInterrupt marks a running thread finished: CPython 3.11's
    Thread._wait_for_tstate_lock, the bpo-45274 fix) and not an Event (a
    KeyboardInterrupt raised inside Event.wait can leave its Condition's
    lock held, and the worker's set() then blocks for ever). The list, not
    the lock, says the render ended. An exception raised into this thread
    meanwhile (a handler of the caller's) sets the flag and waits for the
    render to stop before it goes on."""
    argv = (ctypes.c_char_p * (len(words) + 1))(*[w.encode() for w in words], None)
    interrupt, out = ctypes.c_int(0), ctypes.c_void_p()
    message = ctypes.create_string_buffer(8192)
    status, ended, finished = [], [], threading.Lock()
    finished.acquire()

    def work():
        try:
            status.append(lib.refrender_render(len(words), argv, ctypes.byref(interrupt), ctypes.byref(out),
                                               message, len(message)))
        finally:
            ended.append(True)
            finished.release()
    worker = threading.Thread(target=work, name="refrender", daemon=True)
    with _sigint_sets(interrupt):
        try:
            worker.start()
            while not ended:
                finished.acquire(timeout=0.05)
        except BaseException:  # raised into this thread: the render must stop before this goes on
            interrupt.value = 1
            if _began(worker):
                _wait(ended, finished)
            if out.value:
                lib.refrender_result_free(out)
            raise
    if interrupt.value and status[0] == 0:  # Ctrl-C after the render's last look at the flag: still Ctrl-C
        if out.value:
            lib.refrender_result_free(out)
        return 130, ctypes.c_void_p(), "interrupted"
    return status[0], out, message.value.decode(errors="replace")


def render(scene, *, params=None, **options):
    """Renders scene (an XML file) as `refrender SCENE --OPTION=VALUE ...`
    does and returns its final image (Render). Options are the command
    line's, with '_' for '-': spp=16, tspp=64, batches=4, seed=7,
    res=(64, 36) or "64x36", time_integration="exact", target_error="0.5lv",
    quiet=True; params={"name": value} gives -D name=value. Outputs (-o,
    preview, pass, checkpoint, resume, frames) are refused: the image is
    returned. Raises RenderError with the command line's message, or
    KeyboardInterrupt when interrupted (no image)."""
    lib = _library.load()
    with _LOCK:
        status, out, message = _run(lib, ["refrender", *command_words(scene, params, **options)])
    if status == 130:
        raise KeyboardInterrupt(message)
    if status:
        raise RenderError(message, status)
    try:
        return _result(lib, out)
    finally:
        lib.refrender_result_free(out)


def version():
    """'refrender VERSION (build ID)' of the library, as `refrender --version`."""
    return _library.load().refrender_version().decode()
