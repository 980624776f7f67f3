"""Frame sequences for compare.py: a printf-style pattern ('gt.%04d.exr')
or a directory stands for one image per frame; frames pair by number, and a
refrender image that names its frame (header refrender:frame) must name the
same one."""
import os
import re

from imagecompare import CompareError

IMAGE_EXTENSIONS = (".exr", ".png", ".tif", ".tiff", ".jpg", ".jpeg", ".hdr")
_FIELD = re.compile(r"%0?\d*d")


def is_sequence(spec):
    return os.path.isdir(spec) or bool(_FIELD.search(spec))


def parse_frames(text):
    m = re.fullmatch(r"(-?\d+)-(-?\d+)", text or "")
    if not m or int(m.group(1)) > int(m.group(2)):
        raise CompareError(f"--frames {text}: expected A-B with A <= B")
    return list(range(int(m.group(1)), int(m.group(2)) + 1))


def _directory_frames(path):
    """Frame number -> file: the last number in each image file's name."""
    found = {}
    for name in sorted(os.listdir(path)):
        numbers = re.findall(r"\d+", os.path.splitext(name)[0])
        if not name.lower().endswith(IMAGE_EXTENSIONS) or not numbers:
            continue
        frame = int(numbers[-1])
        if frame in found:
            raise CompareError(f"{path}: {found[frame]} and {name} are both frame {frame}")
        found[frame] = os.path.join(path, name)
    if not found:
        raise CompareError(f"{path}: no numbered images in the directory")
    return found


def expand(spec, frames):
    """Frame -> path for a pattern (needs frames) or a directory (frames, if
    given, select)."""
    if os.path.isdir(spec):
        found = _directory_frames(spec)
        if frames is None:
            return found
        missing = [f for f in frames if f not in found]
        if missing:
            raise CompareError(f"{spec}: no image for frame {missing[0]}")
        return {f: found[f] for f in frames}
    if frames is None:
        raise CompareError(f"{spec}: a frame pattern needs --frames A-B")
    if len(_FIELD.findall(spec)) != 1:
        raise CompareError(f"{spec}: a frame pattern holds exactly one field such as %04d")
    return {f: spec % f for f in frames}


def check_frame(path, header, frame):
    """A refrender image that names its frame must be the frame it is paired as."""
    named = header.get("refrender:frame")
    if named is not None and int(named) != frame:
        raise CompareError(f"{path}: its header says frame {int(named)}, but it is paired as frame {frame}")


def pairs(reference, tests, frames):
    """[(frame, reference path, [test paths])] over the reference's frames."""
    ref = expand(reference, frames)
    order = sorted(ref)
    per_test = []
    for t in tests:
        if not is_sequence(t):
            raise CompareError(f"{t}: the reference is a sequence, so every test must be one (pattern or directory)")
        m = expand(t, order)
        per_test.append(m)
    return [(f, ref[f], [m[f] for m in per_test]) for f in order]
