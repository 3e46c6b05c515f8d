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
- ``COEXIST_CACHE=0`` turns the cache off (everything is built in the process, same numbers); an
  unwritable cache directory only costs the time.

Generated numpy code is stored as a Python module (``*.py``; Python keeps its bytecode beside it), a
CasADi function in CasADi's own serialisation (``*.casadi``). Compiled shared libraries
(:mod:`coexist.numerics.compiled`) live in the same directory.
"""

from __future__ import annotations

import hashlib
import os
import tempfile
from pathlib import Path

_DIGESTS: dict = {}


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
        fd, tmp = tempfile.mkstemp(prefix=f".{path.stem}-", suffix=path.suffix + ".tmp", dir=path.parent)
    except OSError:
        return False
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
        os.replace(tmp, path)
        return True
    except OSError:
        return False
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


def python_module(name: str, cache_key: str, make_source):
    """A module of generated Python code: loaded from the cache, else made by ``make_source()``, stored
    and loaded.

    Parameters
    ----------
    name : str
        Stem of the cached file (``{name}-{cache_key}.py``).
    cache_key : str
        Its key (:func:`key`).
    make_source : callable
        ``make_source() -> str``, the module's source, called only on a miss.

    Returns
    -------
    dict
        The module's namespace (its functions by name).
    """
    import importlib.util

    path = cache_dir() / f"{name}-{cache_key}.py"
    if enabled() and (path.exists() or write_atomic(path, make_source().encode())):
        try:
            spec = importlib.util.spec_from_file_location(f"_coexist_generated_{name}_{cache_key}", path)
            module = importlib.util.module_from_spec(spec)  # type: ignore[arg-type]
            spec.loader.exec_module(module)  # type: ignore[union-attr]
            return vars(module)
        except Exception:  # noqa: BLE001 - a damaged cache file: rebuilt below, and replaced
            source = make_source()
            write_atomic(path, source.encode())
            namespace: dict = {}
            exec(compile(source, f"<coexist generated {name}>", "exec"), namespace)
            return namespace
    namespace = {}
    exec(compile(make_source(), f"<coexist generated {name}>", "exec"), namespace)
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
            return ca.Function.deserialize(path.read_text())
        except (OSError, RuntimeError, UnicodeDecodeError):
            pass  # a damaged file: rebuild and overwrite it
    fun = make()
    if enabled():
        write_atomic(path, fun.serialize().encode())
    return fun
