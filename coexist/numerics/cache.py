"""A disk cache of generated code, so that a process does not rebuild what an earlier one built.

Every process needs the model's numpy functions (generated from CasADi expressions by
:mod:`coexist.numerics.codegen`) and the CasADi attempt functions of small-batch shooting; building
them costs 60–80 ms, more than one curve. They are kept, per machine:

- in ``$COEXIST_CACHE_DIR``, else ``$XDG_CACHE_HOME/coexist``, else ``~/.cache/coexist``;
- under a key that stands for everything that determines them (see :func:`key`): the model's effects
  and parameters, the library's own source files that generate them, and the CasADi version; so an
  entry is reused exactly when it would be generated the same again (a changed source file is a new
  key, never a stale hit);
- written to a temporary file in the cache directory and renamed into place, so concurrent processes
  see a whole file or none; a file that does not load is rebuilt in memory;
- bounded: past :data:`MAX_BYTES` the least recently used files are removed (a hit marks its file
  used), so a sweep over many materials does not fill the disk;
- ``COEXIST_CACHE=0`` turns the cache off (everything is built in the process, same numbers); an
  unwritable cache directory only costs the time.

Generated numpy code is stored as a Python module (``*.py``) with its compiled code (``*.marshal``), a
CasADi function in CasADi's own serialisation (``*.casadi``). Compiled shared libraries
(:mod:`coexist.numerics.compiled`) live in the same directory.
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

_DIGESTS: dict = {}
#: the cache's size bound (bytes); past it the least recently used files go
MAX_BYTES = 256 * 2**20


def cache_dir() -> Path:
    """Where generated code is kept (created when the first entry is written).

    Returns
    -------
    pathlib.Path
        ``$COEXIST_CACHE_DIR`` if set, else ``$XDG_CACHE_HOME/coexist``, else ``~/.cache/coexist``.
    """
    env = os.environ.get("COEXIST_CACHE_DIR")
    if env:
        return Path(env)
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "coexist"


def enabled() -> bool:
    """Whether the disk cache is used (``COEXIST_CACHE`` not ``0``, ``false``, ``no`` or ``off``).

    Returns
    -------
    bool
        True unless the environment turns the cache off.
    """
    return os.environ.get("COEXIST_CACHE", "1").lower() not in ("0", "false", "no", "off")


def source_digest(files) -> str:
    """SHA-256 of the package's own source files ``files`` (paths relative to the package), memoised.

    Parameters
    ----------
    files : sequence of str
        Paths such as ``"model.py"`` or ``"numerics/codegen.py"``.

    Returns
    -------
    str
        The hex digest of their bytes, in the order given.
    """
    files = tuple(files)
    if files not in _DIGESTS:
        here = Path(__file__).resolve().parent.parent
        h = hashlib.sha256()
        for f in files:
            h.update(f.encode())
            h.update((here / f).read_bytes())
        _DIGESTS[files] = h.hexdigest()
    return _DIGESTS[files]


def key(*parts) -> str:
    """A cache key: the first 20 hex digits of the SHA-256 of ``repr(parts)`` and CasADi's version.

    Parameters
    ----------
    *parts
        Whatever determines the cached object (their ``repr`` must be deterministic).

    Returns
    -------
    str
        20 hex digits.
    """
    import casadi as ca

    text = repr((parts, getattr(ca, "__version__", "?")))
    return hashlib.sha256(text.encode()).hexdigest()[:20]


def write_atomic(path: Path, data: bytes) -> bool:
    """Write ``data`` to ``path`` through a temporary file renamed into place.

    Parameters
    ----------
    path : pathlib.Path
        The final file (its folder is created if missing).
    data : bytes
        Its content.

    Returns
    -------
    bool
        True if written; False if the folder cannot be created or written (the caller goes on
        without the cache).
    """
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        import tempfile  # only a process that writes the cache needs it

        fd, tmp = tempfile.mkstemp(prefix=f".{path.stem}-", suffix=path.suffix + ".tmp", dir=path.parent)
    except OSError:
        return False
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
        os.replace(tmp, path)
        prune(path.parent)
        return True
    except OSError:
        return False
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


def prune(folder: Path, max_bytes: int | None = None) -> int:
    """Remove the least recently used files of ``folder`` until it holds at most ``max_bytes``.

    Parameters
    ----------
    folder : pathlib.Path
        The cache directory.
    max_bytes : int, optional
        The bound (default :data:`MAX_BYTES`).

    Returns
    -------
    int
        Files removed (files another process removes first are skipped).
    """
    limit = MAX_BYTES if max_bytes is None else max_bytes
    entries = []
    try:
        with os.scandir(folder) as listing:  # closed even when a stat fails
            for e in listing:
                try:
                    if e.is_file():
                        st = e.stat()
                        entries.append((st.st_mtime, st.st_size, e.path))
                except OSError:  # removed by another process meanwhile: not ours to count
                    continue
    except OSError:
        return 0
    total = sum(size for _, size, _ in entries)
    removed = 0
    for _, size, name in sorted(entries):
        if total <= limit:
            break
        try:
            os.unlink(name)
            removed += 1
        except OSError:
            pass
        total -= size
    return removed


def _touch(path: Path) -> None:
    try:
        os.utime(path)
    except OSError:
        pass


def python_module(name: str, cache_key: str, make_source):
    """A module of generated Python code: loaded from the cache, else made by ``make_source()``, stored
    and loaded.

    The source is kept as ``{name}-{cache_key}.py`` (for the reader, and as the code's file name) and its
    compiled code beside it (``.{cache_tag}.marshal``, written by the library itself, so that the cache
    works also where Python writes no bytecode, ``PYTHONDONTWRITEBYTECODE``).

    Parameters
    ----------
    name : str
        Stem of the cached files.
    cache_key : str
        Their key (:func:`key`).
    make_source : callable
        ``make_source() -> str``, the module's source, called only on a miss.

    Returns
    -------
    dict
        The module's namespace (its functions by name).
    """
    import marshal
    import sys

    path = cache_dir() / f"{name}-{cache_key}.py"
    code_path = path.with_suffix(f".{sys.implementation.cache_tag}.marshal")
    namespace: dict = {"__name__": f"_coexist_generated_{name}"}
    if enabled() and code_path.exists():
        try:
            exec(marshal.loads(code_path.read_bytes()), namespace)
            _touch(code_path)
            return namespace
        except Exception:  # noqa: BLE001 - a damaged cache file: rebuilt below, and replaced
            namespace = {"__name__": f"_coexist_generated_{name}"}
    source = make_source()
    code = compile(source, str(path), "exec")
    if enabled() and write_atomic(path, source.encode()):
        write_atomic(code_path, marshal.dumps(code))
    exec(code, namespace)
    return namespace


def casadi_function(name: str, cache_key: str, make):
    """A CasADi function: deserialised from the cache, else made by ``make()`` and stored.

    Parameters
    ----------
    name : str
        Stem of the cached file (``{name}-{cache_key}.casadi``).
    cache_key : str
        Its key (:func:`key`).
    make : callable
        ``make() -> casadi.Function``, called only on a miss.

    Returns
    -------
    casadi.Function
        The function (deserialising costs about a tenth of building it).
    """
    import casadi as ca

    path = cache_dir() / f"{name}-{cache_key}.casadi"
    if enabled() and path.exists():
        try:
            fun = ca.Function.deserialize(path.read_text())
            _touch(path)
            return fun
        except (OSError, RuntimeError, UnicodeDecodeError):
            pass  # a damaged file: rebuild and overwrite it
    fun = make()
    if enabled():
        write_atomic(path, fun.serialize().encode())
    return fun
