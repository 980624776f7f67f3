"""Frame sequences for compare.py: a printf-style pattern ('gt.%04d.exr')
or a directory stands for one image per frame; frames pair by number, and a
refrender image that names its frame (header refrender:frame) must name the
same one."""
import itertools
import os
import re

from .imagecompare import CompareError

IMAGE_EXTENSIONS = (".exr", ".png", ".tif", ".tiff", ".jpg", ".jpeg", ".hdr")
_FIELD = re.compile(r"%0?\d*d")


def is_sequence(spec):
    return os.path.isdir(spec) or bool(_FIELD.search(spec))


def parse_frames(text):
    """The frames A..B as a range: never a list, so that a range far larger
    than the frames that exist (24-99999999999) costs nothing; expand()
    stops at the first frame that is not there."""
    m = re.fullmatch(r"(-?\d+)-(-?\d+)", text or "")
    if not m or int(m.group(1)) > int(m.group(2)):
        raise CompareError(f"--frames {text}: expected A-B with A <= B")
    return range(int(m.group(1)), int(m.group(2)) + 1)


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
        # the first missing frame is among the first len(found) + 1 of the range
        missing = next((f for f in itertools.islice(frames, len(found) + 1) if f not in found), None)
        if missing is not None:
            raise CompareError(f"{spec}: no image for frame {missing}")
        return {f: found[f] for f in frames}
    if frames is None:
        raise CompareError(f"{spec}: a frame pattern needs --frames A-B")
    if len(_FIELD.findall(spec)) != 1:
        raise CompareError(f"{spec}: a frame pattern holds exactly one field such as %04d")
    paths = {}
    for f in frames:  # stops at the first missing frame: the range is bounded by the files that exist
        if not os.path.exists(spec % f):
            raise CompareError(f"{spec % f}: no such file (frame {f} of {spec})")
        paths[f] = spec % f
    return paths


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
