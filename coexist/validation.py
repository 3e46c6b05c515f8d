"""Argument checks of the public API: every public function and constructor checks the types, shapes and
finiteness of what it is given, and raises :class:`~coexist.errors.SceneError` naming the argument (never
a bare ``TypeError``, ``ValueError`` or a broadcast error from deep inside).

``tests/test_api_validation.py`` calls every public entry point with wrong types, shapes, NaN and
out-of-range values.
"""

from __future__ import annotations

import math
import numbers

import numpy as np

from .errors import SceneError


def escaped(text, keep: str = "") -> str:
    """``text`` (a scene's name, say) with every control character shown as a ``\\xNN`` escape: safe for a terminal
    and drawable by a font. Spaces and the characters in ``keep`` (e.g. ``"\\n"`` for a figure's line breaks)
    stay as they are.

    Parameters
    ----------
    text : object
        Converted with ``str``.
    keep : str, optional
        Further characters to leave unescaped.

    Returns
    -------
    str
    """
    return "".join(ch if ch.isprintable() or ch == " " or ch in keep else f"\\x{ord(ch):02x}" for ch in str(text))


def _describe(value) -> str:
    text = repr(value)
    return text if len(text) <= 40 else text[:37] + "..."


def real(value, name: str, *, lo: float | None = None, lo_open: bool = False, hi: float | None = None) -> float:
    """A finite real number (a Python or numpy int or float; not a bool, not a string), within bounds.

    Parameters
    ----------
    value : object
        What the caller passed.
    name : str
        The argument's name, for the message.
    lo, hi : float, optional
        Bounds (``lo ≤ value ≤ hi``; ``lo < value`` with ``lo_open``).
    lo_open : bool
        Whether the lower bound is excluded.

    Returns
    -------
    float

    Raises
    ------
    SceneError
        Naming ``name``, if the value is not such a number.

    Examples
    --------
    >>> real(2, "jlim", lo=0, lo_open=True)
    2.0
    """
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real):
        raise SceneError(f"must be a number, got {_describe(value)}", name)
    x = float(value)
    if not math.isfinite(x):
        raise SceneError(f"must be a finite number, got {_describe(value)}", name)
    if lo is not None and (x <= lo if lo_open else x < lo):
        raise SceneError(f"must be {'>' if lo_open else '>='} {lo:g}, got {x:g}", name)
    if hi is not None and x > hi:
        raise SceneError(f"must be <= {hi:g}, got {x:g}", name)
    return x


def integer(value, name: str, *, lo: int | None = None, hi: int | None = None) -> int:
    """A whole number (Python or numpy int; not a bool or a float) within bounds.

    Parameters
    ----------
    value : object
    name : str
    lo, hi : int, optional

    Returns
    -------
    int

    Raises
    ------
    SceneError
        Naming ``name``.
    """
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Integral):
        raise SceneError(f"must be a whole number, got {_describe(value)}", name)
    k = int(value)
    if lo is not None and k < lo:
        raise SceneError(
            f"must be at least {lo}" + (f" (and at most {hi})" if hi is not None else "") + f", got {k}", name
        )
    if hi is not None and k > hi:
        raise SceneError(f"must be at most {hi}, got {k}", name)
    return k


def real_array(value, name: str, *, lo: float | None = None, lo_open: bool = False, max_ndim: int = 1) -> np.ndarray:
    """An array of finite real numbers (a scalar becomes shape ``(1,)``), within bounds.

    Parameters
    ----------
    value : object
        A number or a sequence of numbers.
    name : str
    lo : float, optional
        Lower bound of every entry.
    lo_open : bool
        Whether the bound is excluded.
    max_ndim : int
        Largest number of dimensions allowed.

    Returns
    -------
    numpy.ndarray
        At least one-dimensional, dtype float.

    Raises
    ------
    SceneError
        Naming ``name``: not numbers, empty, too many dimensions, not finite, or out of bounds.
    """
    if isinstance(value, (str, bytes)):
        raise SceneError(f"must be numbers, got {_describe(value)}", name)
    try:
        arr = np.atleast_1d(np.asarray(value, dtype=float))
    except (TypeError, ValueError):
        raise SceneError(f"must be numbers, got {_describe(value)}", name) from None
    if arr.dtype == bool or np.asarray(value).dtype == bool:
        raise SceneError(f"must be numbers, got {_describe(value)}", name)
    if arr.size == 0:
        raise SceneError("must not be empty", name)
    if arr.ndim > max_ndim:
        raise SceneError(f"must have at most {max_ndim} dimension(s), got shape {arr.shape}", name)
    if not np.isfinite(arr).all():
        raise SceneError(f"must be finite numbers, got {_describe(value)}", name)
    if lo is not None and (arr <= lo if lo_open else arr < lo).any():
        bad = arr[arr <= lo if lo_open else arr < lo][0]
        raise SceneError(f"must be {'>' if lo_open else '>='} {lo:g}, got {bad:g}", name)
    return arr


def broadcastable(name: str, *arrays: np.ndarray) -> tuple:
    """``arrays`` broadcast to one shape, or a SceneError naming ``name`` and the shapes.

    Parameters
    ----------
    name : str
        The arguments, for the message (e.g. ``"pole_stretch, phi_hat"``).
    *arrays : numpy.ndarray

    Returns
    -------
    tuple of numpy.ndarray
        Each array itself where it has the common shape already, else a read-only broadcast view of it.

    Raises
    ------
    SceneError
        If the shapes do not broadcast.
    """
    try:
        shape = np.broadcast(*arrays).shape
    except ValueError:
        shapes = ", ".join(str(a.shape) for a in arrays)
        raise SceneError(f"shapes {shapes} do not match (give one value or one per state)", name) from None
    # (np.broadcast_arrays, without its overhead: a few microseconds on every small shooting call)
    return tuple(a if a.shape == shape else np.broadcast_to(a, shape) for a in arrays)


def instance(value, kind, name: str, what: str):
    """``value`` if it is an instance of ``kind``, else a SceneError saying what was expected.

    Parameters
    ----------
    value : object
    kind : type or tuple of type
    name : str
        The argument's name.
    what : str
        What is expected, in words (e.g. ``"a Scene (load_scene or parse_scene)"``).

    Returns
    -------
    object
        ``value``.

    Raises
    ------
    SceneError
    """
    if not isinstance(value, kind):
        raise SceneError(f"must be {what}, got {type(value).__name__} {_describe(value)}", name)
    return value


def instances(values, kind, name: str, what: str) -> list:
    """``values`` as a list if it is an iterable (not text) of instances of ``kind``, else a SceneError naming ``name``.

    Parameters
    ----------
    values : object
    kind : type or tuple of type
    name : str
        The argument's name.
    what : str
        What one item is expected to be, in words (e.g. ``"a StableSegment (report.result.segments)"``).

    Returns
    -------
    list

    Raises
    ------
    SceneError
    """
    if isinstance(values, (str, bytes)) or not hasattr(values, "__iter__"):
        raise SceneError(f"must be a list, each item {what}; got {type(values).__name__} {_describe(values)}", name)
    items = list(values)
    for item in items:
        instance(item, kind, name, f"a list, each item {what}; an item")
    return items


def has_methods(value, methods: tuple, name: str, what: str):
    """``value`` if it is an object (not a class) with every method of a Protocol (``methods``), else a SceneError.

    Parameters
    ----------
    value : object
    methods : tuple of str
    name : str
    what : str
        The Protocol, in words.

    Returns
    -------
    object
        ``value``.

    Raises
    ------
    SceneError
    """
    if isinstance(value, type):  # the class itself (Gent, not Gent(97)): its methods are there, unbound
        raise SceneError(f"must be {what}: an instance, got the class {value.__name__} (call it)", name)
    missing = [m for m in methods if not callable(getattr(value, m, None))]
    if missing:
        raise SceneError(
            f"must be {what} (with {', '.join(methods)}), got {type(value).__name__} {_describe(value)}", name
        )
    return value


def settings_or_default(settings):
    """``settings``, or the default :class:`~coexist.settings.SolverSettings` for None.

    Parameters
    ----------
    settings : SolverSettings or None

    Returns
    -------
    SolverSettings

    Raises
    ------
    SceneError
        If ``settings`` is something else (a tolerance given as a number, say).
    """
    from .settings import SolverSettings

    if settings is None:
        return SolverSettings()
    return instance(settings, SolverSettings, "settings", "a SolverSettings (e.g. SolverSettings(rtol=1e-8))")


def membrane_model(model):
    """``model`` if it is a :class:`~coexist.model.MembraneModel`, else a SceneError naming ``model``.

    Parameters
    ----------
    model : object

    Returns
    -------
    MembraneModel

    Raises
    ------
    SceneError
    """
    from .model import MembraneModel

    return instance(model, MembraneModel, "model", "a MembraneModel (e.g. MembraneModel() or build_model('gent', 97))")


def scene(value):
    """``value`` if it is a :class:`~coexist.scene.Scene`, else a SceneError naming ``scene``.

    Parameters
    ----------
    value : object

    Returns
    -------
    Scene

    Raises
    ------
    SceneError
        If ``value`` is not a Scene, or (made with ``dataclasses.replace``) its shear modulus, permittivity,
        thickness or zone radius is not a positive number, or its zone count not a whole number of at least 1.
    """
    from .scene import Scene

    sc = instance(value, Scene, "scene", "a Scene (load_scene('tricircle') or parse_scene(text))")
    # a Scene made by dataclasses.replace bypasses the scene format's checks: the fields every computation divides
    # by or counts with are checked again (a zero radius had been a ZeroDivisionError, 2.5 zones a result; helper-97)
    for name in ("shear_modulus", "relative_permittivity", "thickness", "zone_radius"):
        real(getattr(sc, name), name, lo=0.0, lo_open=True)
    integer(sc.zone_count, "zone_count", lo=1)
    return sc
