"""refrender.compare: compare.py's metrics as the rows its --json prints."""
from .imagecompare import CompareError

# compare.py's outputs: compare() returns its rows and writes nothing
_FILE_OPTIONS = {"json", "csv", "latex", "latex_summary", "heatmaps", "maps", "report", "map_scale", "inset_scale",
                 "diff_range", "flip_range"}


def _words(options):
    words = []
    for name, value in options.items():
        flag = "--" + name.replace("_", "-")
        if name in _FILE_OPTIONS:
            raise CompareError(f"{flag}: compare() returns the rows and writes no file: that is compare.py's")
        if value is True:
            words.append(flag)
        elif value is not None and value is not False:
            for v in (value if isinstance(value, (list, tuple)) else [value]):  # crop=[...], label=[...]: repeated
                words.append(f"{flag}={v}")
    return words


def compare(reference, *tests, **options):
    """compare.py REFERENCE TEST ... --OPTION=VALUE ...: returns the rows its
    --json prints (a list of dicts, one per test, window and frame: MAE,
    RMSE, PSNR, SSIM, FLIP, the share beyond k standard errors, encodings,
    ...). Images are files (or sequences) as compare.py reads them, with
    OpenImageIO; FLIP needs scipy and SSIM scikit-image, as compare.py does.
    Options are compare.py's with '_' for '-' (a list repeats one: crop=[...]);
    its file outputs are refused. Raises CompareError with compare.py's message."""
    from . import comparison
    argv = [str(reference), *map(str, tests), *_words(options)]
    try:
        return comparison.rows_for(argv)
    except SystemExit as e:  # argparse's usage error (already printed to stderr)
        raise CompareError(f"compare.py: bad arguments {argv[len(tests) + 1:]} (exit {e.code}; see its --help)")
