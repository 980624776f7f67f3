"""Inputs and outputs of the Python tools, kept as refrender keeps its own
(src/core/atomicfile.c, README "Guarantees"):

- an input must be a regular file, checked by name before it is opened: a
  FIFO or a device would block the tool or feed it without end;
- an output must not be one of the inputs, compared by file identity (device
  and inode, so ./x, a/../x, a symbolic or a hard link all count), nor an
  existing FIFO, device or directory, which a rename would replace;
- an output is written to a temporary beside it (same directory, so the
  rename cannot cross file systems), flushed and fsync'ed, checked, and only
  then renamed over its name: it is complete or absent, and a failure (a full
  disk) removes the temporary and is reported as one line.

Standard library only, so that every tool can use it (convert_4dgs.py too).
Errors are FileRefused, whose text is one line naming the file and reason."""
import errno
import os
import stat
import tempfile


class FileRefused(Exception):
    """An input or output refused, or an output that could not be written."""


def _kind(mode):
    for test, name in ((stat.S_ISFIFO, "a FIFO"), (stat.S_ISCHR, "a character device"),
                       (stat.S_ISBLK, "a block device"), (stat.S_ISSOCK, "a socket"),
                       (stat.S_ISDIR, "a directory")):
        if test(mode):
            return name
    return "not a regular file"


def _reason(e):
    return (e.strerror or str(e)) if isinstance(e, OSError) else str(e)


def require_regular(path):
    """Refuses (FileRefused) a path that is missing or not a regular file, by
    its name (stat follows symbolic links), before anything opens it."""
    try:
        st = os.stat(path)
    except OSError as e:
        raise FileRefused(f"{path}: {_reason(e)}") from None
    if not stat.S_ISREG(st.st_mode):
        raise FileRefused(f"{path}: is {_kind(st.st_mode)}, not a regular file: refusing to read it")


class Inputs:
    """The identities (device, inode) of a tool's input files, to refuse an
    output that would overwrite one of them."""

    def __init__(self, paths=()):
        self._ids = {}
        for p in paths:
            self.add(p)

    def add(self, path):
        try:
            st = os.stat(path)
        except OSError:
            return  # a missing input is the reader's error to report
        self._ids.setdefault((st.st_dev, st.st_ino), str(path))

    def check_output(self, path, option=None):
        """Refuses an output that is an input (however spelled) or an existing
        non-regular file. `option` ('--json') names it in the message."""
        name = f"{option} {path}" if option else str(path)
        try:
            st = os.stat(path)
        except FileNotFoundError:
            return
        except OSError as e:
            raise FileRefused(f"{name}: {_reason(e)}") from None
        if not stat.S_ISREG(st.st_mode):
            raise FileRefused(f"{name}: is {_kind(st.st_mode)}: an output is written as a new regular file and "
                              "would replace it")
        source = self._ids.get((st.st_dev, st.st_ino))
        if source is not None:
            same = "" if source == str(path) else f" ({source})"
            raise FileRefused(f"{name}: is an input{same}: refusing to overwrite it")

    def check_directory(self, path, option):
        """Refuses an output directory that is an existing non-directory."""
        if os.path.exists(path) and not os.path.isdir(path):
            raise FileRefused(f"{option} {path}: exists and is not a directory")


def _fsync_directory(directory):
    """Makes the rename durable; file systems that cannot sync a directory
    are not an error (the file itself was synced)."""
    try:
        fd = os.open(directory, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


def write_file(path, write, inputs=None, check=None, allow_empty=False):
    """Writes `path` whole or not at all: write(tmp) writes the temporary
    (a path ending in path's own extension, so that a library choosing the
    format by extension chooses the same), which is then fsync'ed, refused if
    empty (unless allow_empty: a library that ignores write errors leaves an
    empty file on a full disk), given to check(tmp) (raising on a damaged
    file), given the mode a new file gets (0666 less the umask; mkstemp's is
    0600) and renamed over `path`. Any failure removes the temporary and
    raises FileRefused naming `path`. A temporary left by a killed process
    is not removed by a later run: its name (".NAME.tmp-...") says what it
    is, and a pid check cannot tell another node's live writer from a dead
    one."""
    path = os.fspath(path)
    if inputs is not None:
        inputs.check_output(path)
    directory, base = os.path.split(os.path.abspath(path))
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{base}.tmp-", suffix=os.path.splitext(base)[1], dir=directory)
    except OSError as e:
        raise FileRefused(f"{path}: cannot create a temporary file beside it: {_reason(e)}") from None
    try:
        os.close(fd)
        write(tmp)
        with open(tmp, "rb+") as f:
            os.fsync(f.fileno())
        if not allow_empty and os.path.getsize(tmp) == 0:
            raise OSError(errno.EIO, "nothing was written (disk full?)")
        if check is not None:
            check(tmp)
        mask = os.umask(0)
        os.umask(mask)
        os.chmod(tmp, 0o666 & ~mask)
        if inputs is not None:  # again just before the rename: the name may have been made a link meanwhile
            inputs.check_output(path)
        os.replace(tmp, path)
    except BaseException as e:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        if isinstance(e, FileRefused):
            raise
        if isinstance(e, Exception):
            raise FileRefused(f"{path}: cannot write: {_reason(e)}") from None
        raise
    _fsync_directory(directory)


def write_bytes(path, data, inputs=None):
    """write_file for bytes already in memory."""
    def put(tmp):
        with open(tmp, "wb") as f:
            f.write(data)

    def complete(tmp):
        if os.path.getsize(tmp) != len(data):
            raise OSError(errno.EIO, f"{os.path.getsize(tmp)} of {len(data)} bytes written")
    write_file(path, put, inputs, complete, allow_empty=True)


def write_text(path, text, inputs=None):
    """write_file for a text (UTF-8)."""
    write_bytes(path, text.encode("utf-8"), inputs)
