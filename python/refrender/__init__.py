"""refrender from any Python environment: ground-truth motion-blurred
images as numpy arrays.

    import refrender
    r = refrender.render("scenes/default.xml", spp=4, tspp=16, batches=4, res=(64, 36))
    r.rgba, r.stderr, r.header["refrender:stderrMax"]

render() runs the command line's render in-process (librefrender.so,
`make python`) and returns what its EXR would hold, bit for bit. Options:
help(refrender.render); the command line's: README.md, `refrender --help`.
compare(reference, test, ...) returns the rows scripts/compare.py --json
prints. The scripts' shared modules are this package's: imagecompare,
flip, safefiles, sequences, comparison (compare.py's body), heatmaps and
figures (matplotlib, imported only with them).
"""
from ._compare import compare
from ._library import LibraryMissing, library_path
from ._render import Render, RenderError, command_words, render, version
from .imagecompare import CompareError

__all__ = ["render", "Render", "RenderError", "compare", "CompareError", "LibraryMissing", "library_path",
           "command_words", "version"]
