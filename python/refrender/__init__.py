"""refrender from any Python environment: ground-truth motion-blurred
images as numpy arrays.

    import refrender
    r = refrender.render("scenes/default.xml", spp=4, tspp=16, batches=4, res=(64, 36))
    r.rgba, r.stderr, r.header["refrender:stderrMax"]

render() runs the command line's render in-process (librefrender.so,
`make python`) and returns what its EXR would hold, bit for bit. Options:
help(refrender.render); the command line's: README.md, `refrender --help`.
"""
from ._library import LibraryMissing, library_path
from ._render import Render, RenderError, command_words, render, version

__all__ = ["render", "Render", "RenderError", "LibraryMissing", "library_path", "command_words", "version"]
