"""One fact, one owner (issue 50, item 5): the facts that several files once restated each by hand
are now said in one place, and this test keeps them there. It reads src/ as text, comments
stripped: the 1e15 reach is one constant (RR_MAX_REACH, core/common.h; it was five names and a
literal in a message); the 1/255 alpha floor is GAUSSIAN_ALPHA_MIN and its squared kernel reach
one function, gaussian_alpha_reach2 (gaussian_hit.h; it was written three ways, a fourth in the
benchmark); outward rounding of bounds goes
through core/interval.h (no nextafter or float-room recipe of its own in accel/ or the Gaussian
bounds); the render tiles and the rasterizers' 16x16 tiles have two names; an image is resolved
into its four planes in one place (film.c's image_planes_resolve); and the Gaussian object's
description (semantics, tileRule, order) is written once (gaussian.c's gaussian_imaging); and
an object's kind is asked of a row, never tested (issue 50, item 2: a kind is named only where an
object is made, in its enum, and as a row of a table); and the AVX2 intrinsics are written only
in core/lanes.h (issue 57 item 5). Each check fails on the tree before that change."""
import re

from conftest import ROOT

COMMENT = re.compile(r"/\*.*?\*/|//[^\n]*", re.S)


def code(path):
    """The file's text without its C comments."""
    return COMMENT.sub(" ", path.read_text())


def sources():
    return {str(p.relative_to(ROOT)): code(p) for p in sorted((ROOT / "src").rglob("*"))
            if p.suffix in (".c", ".h", ".cpp")}


def where(pattern, files=None):
    """The source files whose code matches pattern."""
    rx = re.compile(pattern)
    return sorted(f for f, text in (files or sources()).items() if rx.search(text))


def test_the_reach_limit_is_one_constant():
    assert where(r"\b1(\.0*)?e\+?15\b") == ["src/core/common.h"]
    assert where(r"#define\s+\w*MAX_(ABS|REACH|SCALE)\b") == ["src/core/common.h"]


def test_the_alpha_floor_is_said_once():
    assert where(r"log\([^;]*255") == []  # the reach from GAUSSIAN_ALPHA_MIN, never from 255 again
    assert where(r"log\([^;]*GAUSSIAN_ALPHA_MIN") == ["src/gaussians/gaussian_hit.h"]  # gaussian_alpha_reach2
    assert len(re.findall(r"log\([^;]*GAUSSIAN_ALPHA_MIN", code(ROOT / "src/gaussians/gaussian_hit.h"))) == 1


def test_outward_rounding_goes_through_the_interval_helper():
    bounds = {f: t for f, t in sources().items()
              if f.startswith("src/accel/") or f in ("src/gaussians/gaussian_dynamic.c", "src/gaussians/gaussian_reach.c",
                                                     "src/gaussians/gaussian_cull.c")}
    assert where(r"\bnextafter\(", bounds) == []  # interval_step_out (kbuffer's nextafterf is a cutoff, not a bound)
    assert where(r"1e-30|1\.00001", bounds) == []  # interval_float_room
    assert where(r"DBL_EPSILON\s*/\s*2", bounds) == []  # RR_UNIT_ROUNDOFF


def test_the_two_kinds_of_tile_have_two_names():
    assert len(where(r"\bTILE\b")) <= 1  # the render's tiles of work (render.c), wherever they go
    assert "src/gaussians/gaussian_raster_rules.c" not in where(r"\bTILE\b")
    assert where(r"\bRASTER_TILE\b") == ["src/gaussians/gaussian_raster_rules.c"]


def test_intrinsics_are_written_only_in_the_lanes_header():
    # one place knows the AVX2 intrinsics and their bit-for-bit rules (core/lanes.h); a kernel
    # elsewhere says what it loads (v4d_load3f), not how (issue 57 item 5)
    assert where(r"\b_mm\w*_\w+\(|immintrin") == ["src/core/lanes.h"]


def test_an_image_is_resolved_into_its_planes_in_one_place():
    assert where(r"\bimage_resolve\(") == ["src/render/film.c", "src/render/film.h"]


def test_the_gaussian_objects_description_is_written_once():
    assert where(r'tileRule(=|\\")') == []  # the header's and the export's own spellings
    assert where(r'"tileRule"') == ["src/gaussians/gaussian.c", "src/scenexml/scene_xml.c"]  # the key; the XML attribute


def test_object_kinds_are_rows_not_tests():
    # exact time tested o->kind == OBJECT_SPHERE in exact.c and exact_integrate.c before its
    # rows (render/exact_kinds.c); any comparison, case or ternary on a kind is a test
    kind = re.compile(r"OBJECT_(POINTS|SPHERE|GAUSSIANS)\b")
    # (the enum's last member, OBJECT_KIND_COUNT, names no kind: it is the length every
    # kind-indexed table asserts at compile time, issue 57)
    allowed = re.compile(r"\[OBJECT_\w+\]\s*=|kind\s*=\s*OBJECT_\w+|enum\s*{\s*OBJECT_POINTS, OBJECT_SPHERE, "
                         r"OBJECT_GAUSSIANS, OBJECT_KIND_COUNT\s*}")
    tests = sorted(f for f, text in sources().items() if kind.search(allowed.sub(" ", text)))
    assert tests == []
