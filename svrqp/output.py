"""The one safe writer behind every file a command writes (``simulate``, ``plot``, ``tune``,
``export``, ``bench``, ``demo``).

One rule, one option spelling (``force``, the CLI's ``--force``), for every output path:

* a path that does not exist is written (its parent folders are created);
* an existing **regular file** is replaced only with
  ``force``; without it, :class:`FileExistsError`;
* a **symbolic link** — dangling or not — is never written through: without ``force`` it is refused
  (:class:`FileExistsError`: a dangling link would otherwise send the output wherever it points);
  with ``force`` the link itself is replaced by a regular file, and its target is left untouched;
* anything else that exists — a directory, a FIFO (whose ``open`` blocks forever), a device, a
  socket — is refused with :class:`~svrqp.exceptions.ProblemError`, ``force`` or not.

The bytes go to a temporary file in the same folder, which is then renamed over the path
(``os.replace``): the rename replaces a link rather than following it, and a reader never sees a
half-written file. Call :func:`check_target` before long work so that a refusal comes first, then
write with :func:`write_text` or, for a library that writes a file itself (``DataFrame.to_csv``,
``Figure.savefig``), inside :func:`replacing`.

>>> import tempfile, pathlib
>>> folder = pathlib.Path(tempfile.mkdtemp())
>>> write_text(folder / "a.txt", "one\\n").read_text()
'one\\n'
>>> write_text(folder / "a.txt", "two\\n")
Traceback (most recent call last):
...
FileExistsError: ... exists; pass --force (force=True) to replace it
"""

from __future__ import annotations

import os
import stat
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from svrqp.exceptions import ProblemError

__all__ = ["check_target", "replacing", "write_bytes", "write_text"]


def check_target(path: str | Path, *, force: bool = False) -> Path:
    """Raise unless ``path`` may be written under the rules of this module; return it as a Path.

    Parameters
    ----------
    path : str or Path
        The output path named by the user.
    force : bool
        Replace an existing regular file or symbolic link (never write through the link).

    Raises
    ------
    FileExistsError
        ``path`` is an existing file or symbolic link and ``force`` is false.
    ProblemError
        ``path`` exists and is neither a regular file
        nor a symbolic link (a folder, a FIFO, a device).
    """
    path = Path(path)
    try:
        mode = os.lstat(path).st_mode  # the link itself, not what it points to
    except FileNotFoundError:
        return path
    if stat.S_ISLNK(mode):
        if not force:
            raise FileExistsError(f"{path} is a symbolic link (to {os.readlink(path)!r}); it is "
                                  "never written through: pass --force (force=True) to replace "
                                  "the link itself by a file")
        return path
    if not stat.S_ISREG(mode):
        raise ProblemError(f"{path} exists and is not a regular file ({_kind(mode)}): give the "
                           f"path of a file")
    if not force:
        raise FileExistsError(f"{path} exists; pass --force (force=True) to replace it")
    return path


def _umask() -> int:
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def _kind(mode: int) -> str:
    for test, name in ((stat.S_ISDIR, "a folder"), (stat.S_ISFIFO, "a FIFO"),
                       (stat.S_ISCHR, "a device"),
                       (stat.S_ISBLK, "a device"), (stat.S_ISSOCK, "a socket")):
        if test(mode):
            return name
    return "not a file"


@contextmanager
def replacing(path: str | Path, *, force: bool = False) -> Iterator[Path]:
    """Yield a temporary path (same folder, same suffix) to write; on success it replaces ``path``.

    The target is checked (:func:`check_target`) before and again just before the rename. On an
    error inside the block the temporary file is removed and ``path`` is left as it was.
    """
    path = check_target(path, force=force)
    path.parent.mkdir(parents=True, exist_ok=True)
    handle, name = tempfile.mkstemp(prefix=f".{path.name}.", suffix=path.suffix or ".tmp",
                                    dir=path.parent)
    os.close(handle)
    temporary = Path(name)
    os.chmod(temporary, 0o666 & ~_umask())  # mkstemp's 0600 would outlive the rename
    try:
        yield temporary
        check_target(path, force=force)  # nothing may have appeared there meanwhile
        os.replace(temporary, path)
    finally:
        temporary.unlink(missing_ok=True)


def write_bytes(path: str | Path, data: bytes, *, force: bool = False) -> Path:
    """Write ``data`` to ``path`` under the rules of this module; returns the path written."""
    with replacing(path, force=force) as temporary:
        temporary.write_bytes(data)
    return Path(path)


def write_text(path: str | Path, text: str, *, force: bool = False) -> Path:
    """Write ``text`` (UTF-8) to ``path`` under the
    rules of this module; returns the path written."""
    return write_bytes(path, text.encode("utf-8"), force=force)
