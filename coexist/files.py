"""Writing a file whole or not at all: drawn into a temporary file beside it, then renamed onto it.

The one home of the atomic write (:func:`atomic`, and :func:`temp_file` / :func:`real_target` for writers that
stage several files and rename them together, as the command line's ``Outputs``). The temporary file is made as
``open(target, "w")`` would make the target: a new file gets mode ``0o666`` less the umask (the kernel applies the
process's umask, and a folder's default ACL, to ``os.open``; the umask is never read or changed), an existing file
keeps its permission bits. A target that is a symbolic link is written through, as ``open()`` does: the file the
link resolves to is replaced (the temporary file lies in that file's folder, so the rename stays atomic) and the
link stays a link.
"""

from __future__ import annotations

import os
import secrets
import stat
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from .errors import SceneError

#: names tried for a temporary file before giving up (each a fresh random name)
_ATTEMPTS = 100


def real_target(path: str | Path) -> Path:
    """The file a write to ``path`` changes: ``path`` itself, or for a symbolic link the file it resolves to.

    Parameters
    ----------
    path : str or pathlib.Path

    Returns
    -------
    pathlib.Path
    """
    p = Path(path)
    return Path(os.path.realpath(p)) if p.is_symlink() else p


def temp_file(target: str | Path, suffix: str | None = None) -> Path:
    """Create an empty temporary file in the folder of ``target``'s real file (:func:`real_target`), with the
    permissions ``open(target, "w")`` would leave: an existing target's permission bits, else ``0o666`` less the
    umask.

    Parameters
    ----------
    target : str or pathlib.Path
        The file to be replaced (it need not exist; its folder must).
    suffix : str, optional
        The temporary file's suffix (default: the target's, so a writer choosing the format by suffix sees it).

    Returns
    -------
    pathlib.Path
        The new, empty file (``.{stem}-{random}{suffix}``); the caller renames it onto the real target or
        removes it.

    Raises
    ------
    SceneError
        If ``target`` (or the file its link resolves to) exists and is not a regular file.
    OSError
        If the folder does not take a new file.
    """
    real = real_target(target)
    if real.exists() and not real.is_file():
        # a device, pipe or socket (or a folder): the rename would replace the node itself (helper-95: a link to
        # /dev/full given with --overwrite left a regular file in its place)
        raise SceneError(f"{target} is not a regular file (a folder, device, pipe or socket); give a file path", "path")
    folder = real.parent if str(real.parent) else Path(".")
    suffix = real.suffix if suffix is None else suffix
    try:
        existing: int | None = stat.S_IMODE(os.stat(real).st_mode) & 0o777
    except OSError:
        existing = None
    flags = os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_BINARY", 0)
    for _ in range(_ATTEMPTS):
        tmp = folder / f".{real.stem}-{secrets.token_hex(4)}{suffix}"
        try:
            fd = os.open(tmp, flags, 0o666)  # the kernel applies the umask, as for open()
        except FileExistsError:
            continue
        try:
            if existing is not None and hasattr(os, "fchmod"):
                os.fchmod(fd, existing)  # replacing a file keeps its permissions, as open(..., "w") does
        except OSError:
            os.close(fd)
            tmp.unlink(missing_ok=True)
            raise
        os.close(fd)
        return tmp
    raise FileExistsError(f"no free temporary name in {folder} after {_ATTEMPTS} attempts")


@contextmanager
def atomic(target: str | Path, suffix: str | None = None) -> Iterator[Path]:
    """Write ``target`` atomically: yields a temporary file (:func:`temp_file`) to write to, renamed onto the real
    target (:func:`real_target`: through a symbolic link) when the block ends without error, removed otherwise.

    Parameters
    ----------
    target : str or pathlib.Path
        The file to write (its folder must exist).
    suffix : str, optional
        The temporary file's suffix (default: the target's).

    Yields
    ------
    pathlib.Path
        The temporary file.

    Examples
    --------
    >>> import tempfile
    >>> with tempfile.TemporaryDirectory() as d:
    ...     with atomic(Path(d) / "a.txt") as tmp:
    ...         _ = tmp.write_text("whole")
    ...     (Path(d) / "a.txt").read_text()
    'whole'
    """
    real = real_target(target)
    tmp = temp_file(real, suffix)
    try:
        yield tmp
        os.replace(tmp, real)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
