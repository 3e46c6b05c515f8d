"""Design sweeps: the scene's slow ramp at every point of a grid of scene fields, in parallel, resumable.

A sweep varies scene fields named by their key path, units in the key as in a scene file
(``chamber.closing_pressure_mbar``, ``membrane.zone_radius_mm``, ``zones.count``, ``membrane.material``),
over the Cartesian product of the values given per key. At every point the scene is rebuilt from its
TOML document with the point's values (so every scene rule is checked again; one rule of the sweep's own: a
``membrane.material`` other than ``gent`` drops the scene's ``jlim`` at its points, which the command line
notes, and sweeping it together with ``membrane.jlim`` is refused), and its ramp is run on the
exact continuation layer (:meth:`coexist.simulation.Simulation.ramp`); the point keeps what a designer
needs (:data:`FLOAT_FIELDS`):

* ``spinodal_up_kV`` — where the homogeneous zones lose stability on the way up and one (or more) bulges;
* ``spinodal_down_kV`` — where the bulged state is lost on the way down and the zones return to equal;
* ``hysteresis_kV = spinodal_up_kV − spinodal_down_kV``;
* ``jump_up_kV`` / ``jump_down_kV`` — the first transition up / down where the zones' state jumps (some zone's
  volume or pole stretch changes by more than :data:`JUMP_VOLUME`): the spinodal where the split is a jump (the
  default scene), the fold inside the bulged configuration where the split is continuous (two zones: a pitchfork
  whose bulged branch starts at the homogeneous state), and ``jump_hysteresis_kV`` between them (only where the
  jump down returns from the jump up's landing to its start);
* ``equal_free_energy_kV`` — where a bulged configuration has the free energy of the homogeneous one;
* ``breakdown_kV``, ``range_end_kV`` — where the field reaches the breakdown field, where the ramp leaves
  the model's range (wrinkling);
* ``loss_up_kV`` / ``loss_down_kV`` per configuration (number of bulged zones): where the ramp leaves it;
* the configuration at the top of the ramp, the closing pressure relative to the snap-through,
  ``p̂close/p̂max``, and a ``status`` with a one-line ``reason`` (:data:`STATUSES`).

Each number is an event of the exact continuation with its measured error (``*_error_kV``), never an
interpolation. A point with no answer (its zones cannot hold the closing pressure, a solver failed, ...)
gets a status and its reason, not an exception; its voltages are missing (NaN in :meth:`SweepResult.to_xarray`,
with the status saying why).

Execution: serially (``workers=1``), on a local pool of ``workers`` processes (``spawn``: each worker
rebuilds the model from the scene document; only plain dicts, numbers and strings cross a process
boundary), or on a Dask distributed cluster (``client=``). The points are cut into chunks; with a
``parts_dir`` each finished chunk is written there at once (one small JSON file, written atomically), an
interrupted sweep resumes from them and computes only the missing chunks, and a chunk whose worker died is
computed again (at most ``max_retries`` more times). The cost of a sweep is the number of points times the
cost of one ramp (:mod:`coexist.cost`), divided by the workers: :func:`sweep_cost`.
"""

from __future__ import annotations

import contextlib
import copy
import dataclasses
import hashlib
import itertools
import json
import math
import re
import time
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .errors import CoexistError, ModelRangeError, SceneError, SolverError
from .model import WRINKLING_MODES
from .ramp import JUMP_VOLUME, is_jump
from .scene import Chamber, Scene, VoltagePath, load_scene
from .scene_format import PATTERNS, SCHEMA, UNITS, _resolve, _value, did_you_mean, read_document
from .settings import SolverSettings

#: a sweep with more points than this is refused before it starts
MAX_POINTS = 100_000
#: values one ``START:STOP:N`` range may hold
MAX_AXIS_POINTS = 10_000
#: a sweep whose estimated wall time (with its workers) passes this is refused before it starts (s)
MAX_WALL_SECONDS = 24 * 3600.0
#: format of the parts folder (its manifest says which)
PARTS_FORMAT = 2  # 2: the jump fields (jump_up_kV, ...)

#: per point: voltages in kV of the transitions, and their measured errors (missing where there is none)
FLOAT_FIELDS = (
    "spinodal_up_kV",
    "spinodal_up_error_kV",
    "spinodal_down_kV",
    "spinodal_down_error_kV",
    "hysteresis_kV",
    "jump_up_kV",
    "jump_up_error_kV",
    "jump_down_kV",
    "jump_down_error_kV",
    "jump_hysteresis_kV",
    "equal_free_energy_kV",
    "equal_free_energy_error_kV",
    "breakdown_kV",
    "breakdown_error_kV",
    "range_end_kV",
    "range_end_error_kV",
    "top_voltage_kV",
    "closing_pressure_ratio",
)
#: per point: whole numbers, ``-1`` where there is none
INT_FIELDS = ("bulged_after_jump", "top_bulged")
#: per point: text
STR_FIELDS = ("status", "reason", "top_configuration")

#: every status a point can have, with what it means; the first four are answers, the others failures
STATUSES = {
    "bulges": "on the way up the homogeneous zones lose stability and zones bulge (spinodal_up_kV)",
    "no_bulge": "the zones stay equal up to the top of the ramp",
    "breakdown_first": "the field reaches the breakdown field before any zone bulges",
    "leaves_range": "the ramp leaves the model's range (e.g. the membrane wrinkles) before any zone bulges",
    "no_start": "the zones cannot hold the closing (or controlled) pressure: no state to start from",
    "invalid_scene": "the point's scene breaks a scene rule (the reason names the field)",
    "model_range": "no stable state to start from, or another limit of the model",
    "solver_failed": "a solver did not converge",
    "failed": "another library error",
    "internal_error": "an unexpected error (a bug; please report the reason)",
    "lost": "every worker that computed it died",
}
#: statuses that are answers of the physics (the others are failures)
ANSWERED = ("bulges", "no_bulge", "breakdown_first", "leaves_range")

#: the long names of the per-point quantities (attributes of the labelled result)
DESCRIPTIONS = {
    "spinodal_up_kV": "voltage at which the homogeneous zones lose stability on the way up and zones bulge",
    "spinodal_down_kV": "voltage at which the bulged state is lost on the way down and the zones return to equal",
    "hysteresis_kV": "spinodal_up_kV - spinodal_down_kV",
    "jump_up_kV": "voltage of the first jump of the zones' state on the way up (a zone's volume or pole stretch "
    "changes by more than 2 %): the spinodal, or where the split is continuous the fold inside the bulged "
    "configuration",
    "jump_down_kV": "voltage of the first jump of the zones' state on the way down",
    "jump_hysteresis_kV": "jump_up_kV - jump_down_kV, where the jump down returns from the jump up's landing to its "
    "start",
    "equal_free_energy_kV": "voltage of equal free energy of the homogeneous and the first bulged configuration",
    "breakdown_kV": "voltage at which the largest field reaches the breakdown field",
    "range_end_kV": "voltage at which the ramp first leaves the model's range (e.g. wrinkling)",
    "top_voltage_kV": "the highest voltage of the ramp",
    "closing_pressure_ratio": "closing (or controlled) pressure over the zones' snap-through pressure, p̂close/p̂max",
    "bulged_after_jump": "number of bulged zones after the jump up (-1: no jump)",
    "top_bulged": "number of bulged zones at the top of the ramp (-1: no state there)",
    "top_configuration": "configuration at the top of the ramp ('none': no state there)",
    "status": "what the point's ramp gives: " + "; ".join(f"{k}: {v}" for k, v in STATUSES.items()),
    "reason": "why a point has no jump or no answer, and why any of its transition voltages is missing (NaN)",
    "loss_up_kV": "voltage at which the ramp up leaves the configuration with this many bulged zones",
    "loss_down_kV": "voltage at which the ramp down leaves the configuration with this many bulged zones",
}


# --- the swept keys --------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Axis:
    """One swept scene field and its values.

    Attributes
    ----------
    key : str
        The key path as given, ``section.key_unit``, e.g. ``"membrane.zone_radius_mm"``.
    section, name, unit : str
        Its scene section, field name and unit suffix (``""`` for a field without unit).
    values : tuple
        The values in the key's unit: floats, whole numbers (``zones.count``) or strings (``membrane.material``).
    """

    key: str
    section: str
    name: str
    unit: str
    values: tuple

    @property
    def dim(self) -> str:
        """The dimension's name in the labelled result: ``section_key_unit``, e.g. ``membrane_zone_radius_mm``."""
        return f"{self.section}_{self.toml_key}"

    @property
    def toml_key(self) -> str:
        """The key as written in a scene file, e.g. ``zone_radius_mm``."""
        return f"{self.name}_{self.unit}" if self.unit else self.name

    @property
    def units(self) -> str | None:
        """The unit for people (``"mm"``, ``"MV/m"``), ``"1"`` for a number without unit, None for text."""
        if self.unit:
            return self.unit.replace("_per_", "/")
        return None if SCHEMA[self.section][self.name].kind == "string" else "1"


def parse_key(key: str) -> tuple[str, str, str]:
    """``"membrane.zone_radius_mm"`` -> ``("membrane", "zone_radius", "mm")``, checked against the scene format.

    Parameters
    ----------
    key : str
        A key path ``section.key`` with the unit in the key as in a scene file.

    Returns
    -------
    tuple of str
        ``(section, name, unit)``; ``unit`` is ``""`` for a field without unit.

    Raises
    ------
    SceneError
        For an unknown section, key or unit (the closest valid name suggested), a field that cannot be swept
        (a list of voltages), or a key without its unit (field ``--vary``).
    """
    section, dot, rest = str(key).strip().partition(".")
    if not dot or not rest:
        raise SceneError(f"{key!r}: expected section.key, e.g. membrane.zone_radius_mm", "--vary")
    if section not in SCHEMA:
        hint = did_you_mean(section, SCHEMA) or f"; sections: {', '.join(SCHEMA)}"
        raise SceneError(f"{key!r}: unknown section {section!r}{hint}", "--vary")
    try:
        name, unit = _resolve(section, rest)
    except SceneError as exc:
        raise SceneError(f"{key!r}: {exc.message}", "--vary") from None
    if SCHEMA[section][name].many:
        raise SceneError(f"{key!r}: a list of voltages cannot be swept; sweep voltage.stop_kV or step_kV", "--vary")
    return section, name, unit


#: the values a swept string key may take (besides ``membrane.material``, which has aliases): checked before the
#: first point, as the scene format checks them in a file
_CHOICES = {("membrane", "wrinkling"): WRINKLING_MODES, ("electrodes", "pattern"): PATTERNS}


def parse_values(text: str, section: str, name: str, unit: str, key: str = "") -> tuple:
    """The values of one swept key: ``START:STOP:N`` (``N`` evenly spaced values, both ends included) or
    ``v1,v2,...``, each checked as the scene format checks that key (type, sign, range).

    Parameters
    ----------
    text : str
        ``"19:21:5"`` or ``"19.5,20,20.5"`` (``"gent,neo-hookean"`` for the material).
    section, name, unit : str
        The key (:func:`parse_key`).
    key : str, optional
        The key as given, for messages.

    Returns
    -------
    tuple
        Floats, ints (``zones.count``) or strings (``membrane.material``, in canonical spelling).

    Raises
    ------
    SceneError
        If the text is neither form, ``N`` is not a whole number from 1 to :data:`MAX_AXIS_POINTS`, a value
        breaks the key's rule (a material, wrinkling mode or electrode pattern the scene format does not know),
        a whole-number key gets a fraction, or a value repeats (field ``--vary``).
    """
    from .effects import MATERIALS, canonical_material

    spec = SCHEMA[section][name]
    key = key or f"{section}.{name}" + (f"_{unit}" if unit else "")
    text = str(text).strip()
    where = f"{key}={text}"
    if spec.kind != "string" and text.count(":") == 2:
        a, b, n_text = (s.strip() for s in text.split(":"))
        try:
            start, stop = float(a), float(b)
            n = int(n_text)
        except ValueError:
            raise SceneError(f"{where}: expected START:STOP:N with numbers and a whole N", "--vary") from None
        if not (math.isfinite(start) and math.isfinite(stop)):
            raise SceneError(f"{where}: START and STOP must be finite", "--vary")
        if not 1 <= n <= MAX_AXIS_POINTS:
            raise SceneError(f"{where}: N must be a whole number from 1 to {MAX_AXIS_POINTS}, got {n}", "--vary")
        if n == 1 and start != stop:
            raise SceneError(f"{where}: N = 1 needs START = STOP (or give one value)", "--vary")
        raw: list = [float(x) for x in np.linspace(start, stop, n)]
        if spec.kind == "integer":
            if any(x != round(x) for x in raw):
                raise SceneError(f"{where}: {key} takes whole numbers; these steps give fractions", "--vary")
            raw = [int(round(x)) for x in raw]
    else:
        items = [s.strip() for s in text.split(",")]
        if not any(items):
            raise SceneError(f"{where}: expected START:STOP:N or a list v1,v2,...", "--vary")
        if "" in items:  # "1,,2" or a trailing comma: refused, never silently dropped
            raise SceneError(
                f"{where}: empty item {items.index('') + 1}; separate the values by single commas", "--vary"
            )
        raw = []
        for s in items:
            if spec.kind == "string":
                material = canonical_material(s) if name == "material" else s
                if material is None:
                    raise SceneError(
                        f"{where}: unknown material {s!r}{did_you_mean(s.lower(), MATERIALS)}; use one of "
                        f"{', '.join(MATERIALS)}",
                        "--vary",
                    )
                choices = _CHOICES.get((section, name))
                if choices is not None and s not in choices:
                    raise SceneError(
                        f"{where}: unknown {name} {s!r}{did_you_mean(s, choices)}; use one of {', '.join(choices)}",
                        "--vary",
                    )
                raw.append(material)
                continue
            try:
                raw.append(int(s) if spec.kind == "integer" else float(s))
            except ValueError:
                kind = "whole numbers" if spec.kind == "integer" else "numbers"
                raise SceneError(f"{where}: expected {kind}, got {s!r}", "--vary") from None
    for x in raw:
        try:
            _value(spec, x, unit, f"[{section}].{name}" + (f"_{unit}" if unit else ""))
        except SceneError as exc:
            raise SceneError(f"{where}: {exc}", "--vary") from None
    if len(set(raw)) != len(raw):
        raise SceneError(f"{where}: a value repeats", "--vary")
    if section == "zones" and name == "count" and not all(1 <= x <= 1000 for x in raw):
        raise SceneError(f"{where}: zone counts must be from 1 to 1000", "--vary")
    return tuple(raw)


def parse_vary(option: str) -> Axis:
    """One ``--vary KEY=START:STOP:N`` or ``--vary KEY=v1,v2,...`` as an :class:`Axis`.

    Parameters
    ----------
    option : str
        The option's text.

    Returns
    -------
    Axis

    Raises
    ------
    SceneError
        For a text without ``=``, an unknown key, or bad values (:func:`parse_key`, :func:`parse_values`).
    """
    key, eq, values = str(option).partition("=")
    if not eq:
        raise SceneError(f"{option!r}: expected KEY=START:STOP:N or KEY=v1,v2,...", "--vary")
    section, name, unit = parse_key(key)
    return Axis(key.strip(), section, name, unit, parse_values(values, section, name, unit, key.strip()))


def make_axes(vary) -> tuple[Axis, ...]:
    """The swept keys of ``vary``: a mapping ``{key: values}`` or an iterable of ``--vary`` texts / axes.

    Parameters
    ----------
    vary : mapping or iterable
        ``{"membrane.zone_radius_mm": [21.2, 21.4]}`` (values as a sequence or a ``START:STOP:N`` text), or
        ``["membrane.zone_radius_mm=21.2,21.4", ...]``, or :class:`Axis` objects.

    Returns
    -------
    tuple of Axis
        In the order given; the first varies slowest in the flat point order.

    Raises
    ------
    SceneError
        If nothing is swept, a key is bad, or two keys name the same field (field ``--vary``).
    """
    axes: list[Axis] = []
    if isinstance(vary, Mapping):
        for key, values in vary.items():
            section, name, unit = parse_key(key)
            if not isinstance(values, str) and not isinstance(values, Iterable):
                values = [values]  # one value: a list of one (a bare number was a TypeError)
            text = values if isinstance(values, str) else ",".join(str(v) for v in values)
            axes.append(Axis(str(key).strip(), section, name, unit, parse_values(text, section, name, unit, key)))
    elif isinstance(vary, Iterable) and not isinstance(vary, str):
        for item in vary:
            axes.append(item if isinstance(item, Axis) else parse_vary(item))
    else:
        raise SceneError(f"expected a mapping or a list of KEY=VALUES texts, got {type(vary).__name__}", "--vary")
    if not axes:
        raise SceneError("nothing to sweep: give at least one KEY=VALUES", "--vary")
    seen: dict = {}
    for ax in axes:
        if (ax.section, ax.name) in seen:
            raise SceneError(f"{ax.key}: the same field as {seen[ax.section, ax.name]}", "--vary")
        seen[ax.section, ax.name] = ax.key
    return tuple(axes)


# --- scenes as documents ---------------------------------------------------------------------------------
def scene_document(scene: Scene) -> dict:
    """The scene as a TOML document in SI keys (``zone_radius_m``, ``closing_pressure_Pa``, ...), without
    ``[fitted]``: a plain dict that crosses process boundaries and that :func:`scene_from_document` turns back
    into the same scene (a ramp's values are rebuilt from start, stop and step, as in the file).

    Parameters
    ----------
    scene : Scene

    Returns
    -------
    dict

    A patterned scene keeps its ``[electrodes]`` (pattern and radius fractions) and ``[layers]`` (``passive``, or
    every region's ``regions``) sections, so a sweep point rebuilds the same zones.
    """
    membrane: dict = {
        "material": scene.material,
        "shear_modulus_Pa": scene.shear_modulus,
        "relative_permittivity": scene.relative_permittivity,
        "thickness_m": scene.thickness,
        "zone_radius_m": scene.zone_radius,
        "prestretch": scene.prestretch,
    }
    if scene.jlim is not None:
        membrane["jlim"] = scene.jlim
    if scene.breakdown_field is not None:
        membrane["breakdown_field_V_per_m"] = scene.breakdown_field
    for name in ("wrinkling",):  # fields newer scenes carry (kept when the Scene has them)
        if getattr(scene, name, None) is not None:
            membrane[name] = getattr(scene, name)
    zones: dict = {"count": scene.zone_count}
    if scene.controlled_pressure is not None:
        zones["pressure_Pa"] = scene.controlled_pressure
    doc: dict = {"name": scene.name, "description": scene.description, "membrane": membrane, "zones": zones}
    if scene.patterned:
        electrodes: dict = {"pattern": scene.electrode_pattern}
        for name in ("inner_fraction", "outer_fraction"):
            if getattr(scene, name) is not None:
                electrodes[name] = getattr(scene, name)
        doc["electrodes"] = electrodes
        doc["layers"] = (
            {"regions": list(scene.region_layers)}
            if scene.region_layers is not None
            else {"passive": scene.passive_layers}
        )
    if scene.chamber is not None:
        doc["chamber"] = {
            "volume_m3": scene.chamber.volume,
            "closing_pressure_Pa": scene.chamber.closing_pressure,
            "atmospheric_pressure_Pa": scene.chamber.atmospheric_pressure,
        }
    v = scene.voltage
    if v is not None:
        if v.kind == "ramp":
            doc["voltage"] = {"start_V": v.start, "stop_V": v.stop, "step_V": v.step}
        else:
            doc["voltage"] = {"values_V": [float(x) for x in v.values]}
    return doc


def scene_from_document(doc: dict, source: str = "<sweep>") -> Scene:
    """A scene from a TOML document (as :func:`coexist.scene.parse_scene` builds one from its text).

    Parameters
    ----------
    doc : dict
        A parsed scene document.
    source : str
        Where it came from (messages, ``Scene.source``).

    Returns
    -------
    Scene

    Raises
    ------
    SceneError
        For the first invalid field (:func:`coexist.scene_format.read_document`).
    """
    fields = read_document(doc, source)
    if fields["chamber"] is not None:
        fields["chamber"] = Chamber(**fields["chamber"])
    if fields["voltage"] is not None:
        values = np.array(fields["voltage"].pop("values"), dtype=float)
        values.setflags(write=False)
        fields["voltage"] = VoltagePath(values=values, **fields["voltage"])
    return Scene(**fields)


def user_field_names(scene: Scene, axes) -> Scene:
    """``scene`` (built from a sweep's SI document) with the pressure fields an error names spelled as in a scene
    file and a ``--vary`` key: ``[chamber].closing_pressure_mbar`` and ``[zones].pressure_mbar``, not the
    document's ``closing_pressure_Pa`` (a swept pressure keeps the spelling of its key). Only the names change.

    Parameters
    ----------
    scene : Scene
    axes : sequence of Axis
        The swept keys.

    Returns
    -------
    Scene
    """
    swept = {(ax.section, ax.name) for ax in axes}
    if scene.chamber is not None and ("chamber", "closing_pressure") not in swept:
        chamber = dataclasses.replace(scene.chamber, closing_pressure_field="[chamber].closing_pressure_mbar")
        scene = dataclasses.replace(scene, chamber=chamber)
    if scene.controlled_pressure is not None and ("zones", "pressure") not in swept:
        scene = dataclasses.replace(scene, controlled_pressure_field="[zones].pressure_mbar")
    return scene


def vary_document(doc: dict, axes, values) -> dict:
    """A copy of ``doc`` with each axis's field set to its value (any other spelling of that field removed).

    Setting ``membrane.material`` to a material other than Gent drops ``jlim`` (only Gent takes it; a sweep of
    both is refused by :func:`make_spec`, and :func:`spec_notes` says where jlim is dropped).

    Parameters
    ----------
    doc : dict
        The base scene document (:func:`scene_document`).
    axes : sequence of Axis
    values : sequence
        One value per axis.

    Returns
    -------
    dict
    """
    out = copy.deepcopy(doc)
    swept = {(ax.section, ax.name) for ax in axes}
    for ax, value in zip(axes, values):
        table = out.setdefault(ax.section, {})
        for k in list(table):
            if (
                k == ax.name
                or k.startswith(ax.name + "_")
                and k[len(ax.name) + 1 :] in UNITS.get(SCHEMA[ax.section][ax.name].kind, {})
            ):
                del table[k]
        if ax.section == "voltage" and ax.name in ("start", "stop", "step"):
            table.pop("values_V", None)
        table[ax.toml_key] = value
        if ax.name == "material" and value != "gent" and ("membrane", "jlim") not in swept:
            table.pop("jlim", None)
    return out


# --- the sweep's definition ----------------------------------------------------------------------------
@dataclass(frozen=True)
class SweepSpec:
    """What a sweep computes: a base scene document, the swept keys and the solver settings.

    Attributes
    ----------
    document : dict
        The base scene (:func:`scene_document`).
    source : str
        Where the base scene came from.
    axes : tuple of Axis
        The swept keys; the points are their Cartesian product, the first axis varying slowest.
    settings : SolverSettings
    """

    document: dict
    source: str
    axes: tuple
    settings: SolverSettings

    @property
    def shape(self) -> tuple:
        """Number of values per axis."""
        return tuple(len(ax.values) for ax in self.axes)

    @property
    def size(self) -> int:
        """Number of points."""
        return int(math.prod(self.shape))

    def values_at(self, index: int) -> tuple:
        """The swept values of the point with flat index ``index`` (C order).

        Parameters
        ----------
        index : int

        Returns
        -------
        tuple
            One value per axis.
        """
        multi = np.unravel_index(int(index), self.shape)
        return tuple(ax.values[int(i)] for ax, i in zip(self.axes, multi))

    def scene_at(self, index: int) -> Scene:
        """The scene of point ``index``.

        Parameters
        ----------
        index : int

        Returns
        -------
        Scene

        Raises
        ------
        SceneError
            If the point's values break a scene rule.
        """
        doc = vary_document(self.document, self.axes, self.values_at(index))
        return user_field_names(scene_from_document(doc, f"{self.source} at {self.describe(index)}"), self.axes)

    def describe(self, index: int) -> str:
        """``"membrane.zone_radius_mm=21.2, zones.count=3"``: the point's swept values.

        Parameters
        ----------
        index : int

        Returns
        -------
        str
        """
        return ", ".join(
            f"{ax.key}={v:g}" if isinstance(v, float) else f"{ax.key}={v}"
            for ax, v in zip(self.axes, self.values_at(index))
        )

    def fingerprint(self) -> str:
        """A hash of everything that decides the points' results (scene, axes, settings).

        Returns
        -------
        str
            64 hex digits.
        """
        data = {
            "document": self.document,
            "axes": [(ax.section, ax.name, ax.unit, list(ax.values)) for ax in self.axes],
            "settings": dataclasses.asdict(self.settings),
        }
        return hashlib.sha256(json.dumps(data, sort_keys=True, default=str).encode()).hexdigest()


def make_spec(scene, vary, settings: SolverSettings | None = None) -> SweepSpec:
    """A :class:`SweepSpec` from a scene (a :class:`~coexist.scene.Scene`, a built-in name or a path) and the
    swept keys (:func:`make_axes`).

    Parameters
    ----------
    scene : Scene, str or pathlib.Path
    vary : mapping or iterable
        See :func:`make_axes`.
    settings : SolverSettings, optional
        Default: :class:`SolverSettings`.

    Returns
    -------
    SweepSpec

    Raises
    ------
    SceneError
        For a bad key or value, a scene with no voltage (and none swept), or when the scene cannot be built at
        any corner of the grid (the first corner's error), or when ``membrane.material`` with a material other than
        gent is swept together with ``membrane.jlim`` (only gent takes jlim). A patterned scene is swept like any
        other (its ``[electrodes]`` and ``[layers]`` keys too: ``electrodes.inner_fraction=0.4,0.6``); a pattern key
        on a scene without a pattern is an error of the corners, naming the field.
    """
    from . import validation

    sc = scene if isinstance(scene, Scene) else load_scene(scene)
    settings = validation.settings_or_default(settings)
    axes = make_axes(vary)
    swept = {(ax.section, ax.name): ax for ax in axes}
    material = swept.get(("membrane", "material"))
    others = [] if material is None else [v for v in material.values if v != "gent"]
    if material is not None and others and ("membrane", "jlim") in swept:
        raise SceneError(
            f"{swept['membrane', 'jlim'].key} with {material.key}={','.join(others)}: only the gent material takes "
            "jlim (as in a scene file); sweep the other materials without membrane.jlim",
            "--vary",
        )
    spec = SweepSpec(scene_document(sc), sc.source, axes, settings)
    if spec.size > MAX_POINTS:
        raise SceneError(f"{spec.size:,} points; a sweep takes at most {MAX_POINTS:,}", "--vary")
    errors = []
    for index in _corners(spec):
        try:
            corner = spec.scene_at(index)
        except SceneError as exc:
            errors.append(exc)
            continue
        if corner.voltage is None:
            raise SceneError("the scene has no [voltage]: a sweep runs the ramp at every point", "[voltage]")
    if len(errors) == len(_corners(spec)):
        first = errors[0]
        raise SceneError(f"no corner of the grid is a valid scene: {first}", "--vary")
    return spec


def spec_notes(spec: SweepSpec) -> list[str]:
    """What the sweep's rules change at some points beyond the swept values: a ``membrane.material`` other than
    Gent drops the scene's ``jlim`` there (:func:`vary_document`; only the Gent material takes it).

    Parameters
    ----------
    spec : SweepSpec

    Returns
    -------
    list of str
        One line per rule that applies (empty if none).
    """
    jlim = spec.document.get("membrane", {}).get("jlim")
    notes = []
    for ax in spec.axes:
        others = [v for v in ax.values if v != "gent"] if (ax.section, ax.name) == ("membrane", "material") else []
        if others and jlim is not None:
            notes.append(
                f"{ax.key}={','.join(others)}: the scene's jlim = {jlim:g} is dropped at those points (only the "
                "gent material takes jlim)"
            )
    return notes


def _corners(spec: SweepSpec) -> list[int]:
    ends = [sorted({0, n - 1}) for n in spec.shape]
    return [int(np.ravel_multi_index(c, spec.shape)) for c in itertools.product(*ends)]


# --- one point --------------------------------------------------------------------------------------------
def evaluate_point(spec: SweepSpec, index: int) -> dict:
    """The ramp of point ``index`` summarised as a record; a failure is a status and its reason, never an
    exception (except an interrupt).

    Parameters
    ----------
    spec : SweepSpec
    index : int
        Flat point index.

    Returns
    -------
    dict
        ``index``, the :data:`FLOAT_FIELDS` (None where missing), :data:`INT_FIELDS`, :data:`STR_FIELDS` and
        ``loss_up`` / ``loss_down`` (``[[bulged zones, kV], ...]``).
    """
    from .simulation import Simulation

    try:
        scene = spec.scene_at(index)
    except SceneError as exc:
        return failure_record(index, "invalid_scene", str(exc))
    try:
        with same_code_path(scene):
            sim = Simulation.from_scene(scene, spec.settings)
            report = sim.ramp()
        return summarise(index, sim, report)
    except SceneError as exc:
        pressure_fields = {scene.controlled_pressure_field}
        if scene.chamber is not None:
            pressure_fields.add(scene.chamber.closing_pressure_field)
        return failure_record(index, "no_start" if exc.field in pressure_fields else "invalid_scene", str(exc))
    except ModelRangeError as exc:
        return failure_record(index, "model_range", f"{exc.reason}: {exc}")
    except SolverError as exc:
        return failure_record(index, "solver_failed", str(exc))
    except CoexistError as exc:
        return failure_record(index, "failed", f"{type(exc).__name__}: {exc}")
    except Exception as exc:  # a bug: the sweep goes on, the point says so
        return failure_record(index, "internal_error", f"{type(exc).__name__}: {exc}")


@contextlib.contextmanager
def same_code_path(scene: Scene):
    """Compute one point on the same code path in any process, whatever the process computed before.

    The shooting runs a model's small batches in CasADi's virtual machine for its first
    :data:`coexist.shooting.COMPILE_AFTER` uses in a process and as compiled machine code after (cached on
    disk); both evaluate the same graph but round differently in the last bits, so a point's numbers would
    depend on how many points its process had computed, and on whether another process had already compiled
    the code. Inside this context the scene's model starts with fresh integrators that use the compiled code
    from the first call (loaded from the disk cache, or compiled once per machine); without a C compiler
    every process uses the virtual machine throughout. A library missing from the cache is compiled before the
    point goes on (:func:`coexist.numerics.compiled.waiting`; in the background, an empty cache had left the serial
    points in the virtual machine and the workers on the compiled code). Either way a point gives the same bits
    serially, in a process pool and on a cluster of like machines.

    Parameters
    ----------
    scene : Scene
        The point's scene (its shared model, :meth:`Scene.model`, gets fresh integrators).

    Yields
    ------
    None
    """
    from .numerics.compiled import waiting
    from .shooting import fresh_integrators

    model = scene.model()
    fresh_integrators(model, compile_after=1)
    try:
        with waiting():  # compiled now if the cache lacks it, not in the background while this point runs on
            yield
    finally:
        fresh_integrators(model)


def _one_line(text: str) -> str:
    return " ".join(str(text).split())


def failure_record(index: int, status: str, reason: str) -> dict:
    """The record of a point without an answer.

    Parameters
    ----------
    index : int
    status : str
        One of :data:`STATUSES`.
    reason : str
        Why (made one line).

    Returns
    -------
    dict
        As :func:`evaluate_point`, every voltage None.
    """
    rec: dict = {"index": int(index)}
    rec.update({k: None for k in FLOAT_FIELDS})
    rec.update({k: -1 for k in INT_FIELDS})
    rec.update(status=status, reason=_one_line(reason), top_configuration="none", loss_up=[], loss_down=[])
    return rec


def summarise(index: int, sim, report) -> dict:
    """The record of one ramp (:class:`~coexist.simulation.RampReport`): its transitions in kV with their
    errors (:meth:`~coexist.simulation.RampReport.transition_dict`), the configuration at the top, the status.

    Parameters
    ----------
    index : int
        Flat point index.
    sim : Simulation
        The point's simulation (its ``p̂max``).
    report : RampReport
        Its ramp.

    Returns
    -------
    dict
        As :func:`evaluate_point`.
    """
    result = report.result
    rec = failure_record(index, "no_bulge", "")
    trans = list(result.transitions)

    def first(pred):
        return next((t for t in trans if pred(t)), None)

    def put(name, t):
        if t is not None:
            d = report.transition_dict(t)
            rec[f"{name}_kV"] = d["voltage_kV"]
            rec[f"{name}_error_kV"] = d["voltage_error_kV"]
        return t

    up = put(
        "spinodal_up", first(lambda t: t.direction == "up" and t.kind == "spinodal" and t.from_label == "homogeneous")
    )
    down = None
    for t in trans:
        if t.direction == "down" and t.to_label == "homogeneous" and t.kind in ("spinodal", "merge"):
            down = t
    put("spinodal_down", down)
    jump_up = put("jump_up", next((t for t in trans if t.direction == "up" and is_jump(t)), None))
    jump_down = put("jump_down", next((t for t in trans if t.direction == "down" and is_jump(t)), None))
    if jump_up is not None and jump_down is not None and _reverses(jump_down, jump_up):
        rec["jump_hysteresis_kV"] = rec["jump_up_kV"] - rec["jump_down_kV"]
    broke = put("breakdown", first(lambda t: t.kind == "breakdown"))
    left = put("range_end", first(lambda t: t.kind == "no_stable_state"))
    eq = next((t for t in result.equal_free_energy if "homogeneous" in (t.from_label, t.to_label)), None)
    put("equal_free_energy", eq)
    if up is not None and down is not None:
        rec["hysteresis_kV"] = rec["spinodal_up_kV"] - rec["spinodal_down_kV"]
    for direction in ("up", "down"):
        seen: dict = {}
        current = None  # the number of bulged zones the ramp is in, from the last transition's landing
        for t in trans:
            if t.direction != direction:
                continue
            # the configuration left is the one the ramp is in (a merge's own state is the symmetric one, k = 0); a
            # jump to another state of it (two zones: the 1-of-2 branch's folds at 4.106 and 3.949 kV) does not leave
            # it: the ramp leaves it at 4.352 (range end) and 3.852 kV (merge) (review, helper-74)
            before = current if current is not None else _bulged(t.state_before, t.from_label)
            after = _bulged(t.state_after, t.to_label)
            if (
                t.kind in ("spinodal", "merge", "no_stable_state", "breakdown")
                and before is not None
                and after != before
            ):
                seen.setdefault(before, report.transition_dict(t)["voltage_kV"])
            current = after
        rec[f"loss_{direction}"] = sorted([k, v] for k, v in seen.items())
    if result.steps:
        top = max(range(len(result.steps)), key=lambda i: (result.steps[i].phi_hat, -i))
        s = result.steps[top]
        rec["top_voltage_kV"] = float(report.voltage_kV(s.phi_hat))
        rec["top_configuration"] = s.segment.label if s.segment is not None and s.state is not None else "none"
        rec["top_bulged"] = -1 if s.state is None else _bulged(s.state, rec["top_configuration"])
    scene = sim.scene
    p_close = scene.chamber.closing_pressure if scene.chamber is not None else scene.controlled_pressure
    rec["closing_pressure_ratio"] = float(scene.p_hat(p_close)) / float(sim.p_hat_max)
    if up is not None:
        rec["status"] = "bulges"
        rec["bulged_after_jump"] = -1 if up.state_after is None else _bulged(up.state_after, up.to_label)
        rec["reason"] = ""
    elif broke is not None:
        rec["status"] = "breakdown_first"
        # seven significant figures, at any scale (six decimals printed nothing of a micro-actuator's 1e-4 kV)
        rec["reason"] = _one_line(f"breakdown at {rec['breakdown_kV']:#.7g} kV in {broke.from_label}: {broke.reason}")
    elif left is not None:
        rec["status"] = "leaves_range"
        rec["reason"] = _one_line(f"{left.from_label} at {rec['range_end_kV']:#.7g} kV: {left.reason}")
    else:
        rec["reason"] = f"the zones stay equal up to {rec['top_voltage_kV']:.6g} kV"
    missing = _missing_reasons(rec, sim, report)
    if missing:
        rec["reason"] = _one_line("; ".join(([rec["reason"]] if rec["reason"] else []) + missing))
    return rec


def _missing_reasons(rec: dict, sim, report) -> list:
    """Why each transition voltage of an answered record that its status does not already explain is
    missing (NaN in the dataset): one clause per field, e.g. ``"no breakdown_kV: the field stays below
    the breakdown field"``. With status ``bulges`` the spinodal up is always there; with the other
    statuses its absence (and that of the spinodal down and the hysteresis) is the status itself.
    """
    result = report.result
    out = []
    if rec["status"] == "bulges" and rec["spinodal_down_kV"] is None:
        downs = [s for s in result.steps if s.direction == "down"]
        if not downs:
            why = "the path does not come back down"
        else:
            last = downs[-1]
            where = last.segment.label if last.segment is not None and last.state is not None else "no stable state"
            why = (
                "on the way down the zones do not return to the homogeneous state "
                f"({where} at {float(report.voltage_kV(last.phi_hat)):.6g} kV, the path's last voltage down)"
            )
        out.append(f"no spinodal_down_kV (nor hysteresis_kV): {why}")
    if rec["equal_free_energy_kV"] is None:
        homog = [g for g in result.segments if g.label == "homogeneous"]
        others = [g for g in result.segments if g.label != "homogeneous"]

        def overlap(a, b):
            return min(a.phi_range[1], b.phi_range[1]) > max(a.phi_range[0], b.phi_range[0])

        if not homog or not others:
            why = "the ramp does not visit both the homogeneous and a bulged configuration"
        elif not any(overlap(a, b) for a in homog for b in others):
            why = "no bulged configuration the ramp visits is stable where the homogeneous one is"
        else:
            why = (
                "the free energies of the homogeneous and the visited bulged configurations do not cross "
                "where both are stable"
            )
        out.append(f"no equal_free_energy_kV: {why}")
    if rec["breakdown_kV"] is None:
        why = (
            "no breakdown field given"
            if sim.scene.breakdown_field is None
            else "the field stays below the breakdown field on the path"
        )
        out.append(f"no breakdown_kV: {why}")
    if rec["range_end_kV"] is None:
        out.append("no range_end_kV: the ramp stays in the model's range")
    for way in ("up", "down"):
        if rec[f"jump_{way}_kV"] is None:
            moves = [s for s in result.steps if s.direction == way]
            why = (
                f"the path does not go {way}"
                if not moves
                else f"on the way {way} no transition moves a zone's volume or pole stretch by more than "
                f"{JUMP_VOLUME:.0%}"
            )
            out.append(f"no jump_{way}_kV (nor jump_hysteresis_kV): {why}")
    if rec["jump_up_kV"] is not None and rec["jump_down_kV"] is not None and rec["jump_hysteresis_kV"] is None:
        trans = result.transitions
        up = next(t for t in trans if t.direction == "up" and is_jump(t))
        down = next(t for t in trans if t.direction == "down" and is_jump(t))
        out.append(
            f"no jump_hysteresis_kV: the first jump down ({down.from_label} -> {down.to_label}) does not return "
            f"from the first jump up ({up.from_label} -> {up.to_label})"
        )
    return out


def _bulged(state, label: str):
    """The number of bulged zones of ``state`` (None without one): all of them in a homogeneous state past the zones'
    pressure maximum (its label ends in "all bulged"; a homogeneous configuration counts 0 bulged zones: under
    pressure control the top of the ramp read "homogeneous, all bulged" beside ``top_bulged`` 0; review, helper-82)."""
    if state is None:
        return None
    return int(state.zones) if label.endswith("all bulged") else int(state.k)


def _reverses(down, up) -> bool:
    """Whether the jump ``down`` goes back from the state the jump ``up`` landed in to the one it left (by their
    configurations' labels; "all bulged" marks the one branch a label tells apart): only then is
    ``jump_up − jump_down`` a hysteresis (Gent 300: the first jump down is a fold from the large bulged branch to
    the small one, 0.66 kV above the jump up; review, helper-82)."""
    return down.from_label == up.to_label and down.to_label == up.from_label


def _run_chunk(spec: SweepSpec, indices: list, evaluate: Callable | None = None) -> list:
    """Evaluate the points ``indices`` (in a worker): a list of records."""
    evaluate = evaluate or evaluate_point
    return [evaluate(spec, int(i)) for i in indices]


# --- cost -----------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class SweepCost:
    """The estimated cost of a sweep (from :func:`coexist.cost.ramp_cost` of its costliest corner).

    Attributes
    ----------
    points : int
    workers : int
    seconds_per_point : float
        Estimated compute time of one point.
    seconds : float
        Estimated wall time: ``points × seconds_per_point / workers`` (plus the workers' start-up).
    memory_bytes : float
        Estimated memory of one worker.
    """

    points: int
    workers: int
    seconds_per_point: float
    seconds: float
    memory_bytes: float

    def describe(self) -> str:
        """One line for people.

        Returns
        -------
        str
        """
        from .cost import _duration

        return (
            f"{self.points} points × about {self.seconds_per_point:.1f} s on {self.workers} worker(s): about "
            f"{_duration(self.seconds)}, {self.memory_bytes / 1e6:.0f} MB per worker"
        )

    def check(self) -> None:
        """Refuse a sweep past the limits.

        Raises
        ------
        SceneError
            If it has more than :data:`MAX_POINTS` points, would take more than :data:`MAX_WALL_SECONDS`, or one
            point's ramp needs more memory than :data:`coexist.cost.MAX_MEMORY_BYTES` (field ``--vary``).
        """
        from .cost import MAX_MEMORY_BYTES, _duration

        if self.points > MAX_POINTS:
            raise SceneError(f"{self.points:,} points; a sweep takes at most {MAX_POINTS:,}", "--vary")
        if self.seconds > MAX_WALL_SECONDS:
            raise SceneError(
                f"estimated {_duration(self.seconds)} ({self.describe()}); the limit is "
                f"{_duration(MAX_WALL_SECONDS)}: fewer points, a larger voltage step or more workers",
                "--vary",
            )
        if self.memory_bytes > MAX_MEMORY_BYTES:
            raise SceneError(
                f"one point's ramp would need about {self.memory_bytes / 1e9:.2g} GB: take a larger voltage step",
                "--vary",
            )


#: seconds of starting one worker process (import, model code loaded from the cache), measured here
SECONDS_WORKER_START = 1.5


def sweep_cost(spec: SweepSpec, workers: int = 1) -> SweepCost:
    """The estimated cost of ``spec`` on ``workers`` workers: the costliest valid corner's ramp
    (:func:`coexist.cost.ramp_solving_seconds`: without its output; patterned zones at their factor) times the
    points, divided by the workers.

    Parameters
    ----------
    spec : SweepSpec
    workers : int
        Processes (or cluster threads) computing points at once.

    Returns
    -------
    SweepCost
    """
    from .cost import BYTES_PER_VOLTAGE, SECONDS_BASE, ramp_solving_seconds

    voltages, per_point = 1, SECONDS_BASE
    for index in _corners(spec):
        try:
            sc = spec.scene_at(index)
        except SceneError:
            continue
        if sc.voltage_hat_path is not None:
            voltages = max(voltages, len(sc.voltage_hat_path))
            per_point = max(per_point, ramp_solving_seconds(sc))
    workers = max(1, int(workers))
    start = SECONDS_WORKER_START if workers > 1 else 0.0
    wall = start + spec.size * per_point / min(workers, spec.size)
    return SweepCost(spec.size, workers, per_point, wall, BYTES_PER_VOLTAGE * voltages)


# --- the result ----------------------------------------------------------------------------------------
@dataclass
class SweepResult:
    """The records of every point of a sweep, and how they were obtained.

    Attributes
    ----------
    spec : SweepSpec
    records : list of dict
        One per point, in flat (C) order of the grid (:func:`evaluate_point`).
    computed : int
        Points computed by this run.
    reused : int
        Points read from the parts of an earlier, interrupted run.
    retried_chunks : int
        Chunks computed again because their worker died.
    seconds : float
        Wall time of this run.
    workers : int
        Workers that computed (1: serial).
    """

    spec: SweepSpec
    records: list
    computed: int = 0
    reused: int = 0
    retried_chunks: int = 0
    seconds: float = 0.0
    workers: int = 1
    executor: str = "serial"
    notes: list = field(default_factory=list)

    def counts(self) -> dict:
        """Points per status.

        Returns
        -------
        dict of str to int
        """
        out: dict = {}
        for r in self.records:
            out[r["status"]] = out.get(r["status"], 0) + 1
        return out

    def to_xarray(self):
        """The sweep as an :class:`xarray.Dataset` (:func:`coexist.labelled.sweep_dataset`): one dimension per
        swept key (coordinates in the key's unit, ``units`` in the attributes) and ``configuration`` (bulged zones).

        Returns
        -------
        xarray.Dataset
        """
        from .labelled import sweep_dataset

        return sweep_dataset(self)

    def to_netcdf(self, path) -> Path:
        """Write :meth:`to_xarray` to a netCDF file (``h5netcdf``), atomically (a temporary file renamed).

        Parameters
        ----------
        path : str or pathlib.Path

        Returns
        -------
        pathlib.Path
        """
        from .labelled import write_netcdf

        return write_netcdf(self.to_xarray(), path)


# --- parts: finished chunks on disk --------------------------------------------------------------------
class Parts:
    """The finished chunks of one sweep in a folder: ``manifest.json`` and ``chunk-NNNNNN.json`` files, each
    written to a temporary name and renamed (a file that exists is complete).

    Parameters
    ----------
    folder : pathlib.Path
    spec : SweepSpec
    chunk_size : int
    """

    def __init__(self, folder: Path, spec: SweepSpec, chunk_size: int):
        self.folder = Path(folder)
        self.spec = spec
        self.chunk_size = int(chunk_size)

    def manifest(self) -> dict:
        """What identifies the sweep the parts belong to.

        Returns
        -------
        dict
        """
        return {
            "format": PARTS_FORMAT,
            "fingerprint": self.spec.fingerprint(),
            "points": self.spec.size,
            "chunk_size": self.chunk_size,
            "keys": [ax.key for ax in self.spec.axes],
        }

    @staticmethod
    def read_manifest(folder: Path) -> dict | None:
        """The manifest of a parts folder, None if it has none that can be read.

        Parameters
        ----------
        folder : pathlib.Path

        Returns
        -------
        dict or None
        """
        try:
            return json.loads((Path(folder) / "manifest.json").read_text(encoding="utf-8"))
        except (OSError, ValueError):
            return None

    def create(self) -> None:
        """Make the folder and write the manifest."""
        self.folder.mkdir(parents=True, exist_ok=True)
        _atomic_write(self.folder / "manifest.json", json.dumps(self.manifest(), indent=1))

    def path(self, chunk: int) -> Path:
        """The file of chunk ``chunk``.

        Parameters
        ----------
        chunk : int

        Returns
        -------
        pathlib.Path
        """
        return self.folder / f"chunk-{int(chunk):06d}.json"

    def write(self, chunk: int, records: list) -> None:
        """Write one finished chunk.

        Parameters
        ----------
        chunk : int
        records : list of dict
        """
        _atomic_write(self.path(chunk), json.dumps({"chunk": int(chunk), "records": records}, allow_nan=False))

    def read(self, chunk: int, indices: list) -> list | None:
        """The records of chunk ``chunk`` if its file holds exactly the points ``indices``, else None.

        Parameters
        ----------
        chunk : int
        indices : list of int

        Returns
        -------
        list of dict or None
        """
        try:
            data = json.loads(self.path(chunk).read_text(encoding="utf-8"))
            records = data["records"]
            if [int(r["index"]) for r in records] != [int(i) for i in indices]:
                return None
            return records
        except (OSError, ValueError, KeyError, TypeError):
            return None

    def remove(self) -> None:
        """Delete the parts and then the folder, if it is empty (after the merged result is written): only files
        a sweep writes there are removed (:func:`check_parts_folder` refuses a folder holding others)."""
        remove_parts(self.folder)


#: the files a sweep writes into its parts folder: the manifest, the chunks, and their temporary files (a run
#: killed while writing one leaves it: :func:`coexist.files.temp_file` names them ``.{stem}-{random}{suffix}``)
_PART_FILE = re.compile(r"^(manifest|chunk-\d{6})\.json$|^\.(manifest|chunk-\d{6})-[^/]+\.json$")


def check_parts_folder(folder) -> None:
    """Refuse a parts folder that is not one: a path that is not a folder, or a folder that holds anything a sweep
    does not write (a sweep reads, overwrites and removes what is in it).

    Parameters
    ----------
    folder : str or pathlib.Path
        ``FILE.parts`` (:func:`parts_folder`); nothing to check where it does not exist.

    Raises
    ------
    SceneError
        Naming the folder and what is in the way (field ``-o``).
    """
    folder = Path(folder)
    if not (folder.exists() or folder.is_symlink()):
        return
    if folder.is_symlink() or not folder.is_dir():
        raise SceneError(
            f"{folder} exists and is not a folder: a sweep to this file keeps its parts there; move it or write to "
            "another file",
            "-o",
        )
    try:
        foreign = sorted(p.name for p in folder.iterdir() if not (p.is_file() and _PART_FILE.match(p.name)))
    except OSError as exc:  # unreadable (permissions): nothing can be resumed or removed there
        raise SceneError(
            f"{folder} cannot be read ({exc.strerror or exc}): move it or write to another file", "-o"
        ) from None
    if foreign:
        shown = ", ".join(foreign[:3]) + (f" and {len(foreign) - 3} more" if len(foreign) > 3 else "")
        raise SceneError(
            f"{folder} holds files a sweep does not write ({shown}): a sweep to this file keeps its parts there and "
            "removes them; move them or write to another file",
            "-o",
        )


def remove_parts(folder) -> None:
    """Remove the files a sweep wrote into ``folder`` (its manifest, chunks and their temporary files) and the
    folder itself once it is empty; anything else stays.

    Parameters
    ----------
    folder : str or pathlib.Path
    """
    folder = Path(folder)
    if folder.is_symlink() or not folder.is_dir():
        return
    for p in folder.iterdir():
        if p.is_file() and _PART_FILE.match(p.name):
            p.unlink(missing_ok=True)
    try:
        folder.rmdir()
    except OSError:
        pass  # something else is in it (or appeared meanwhile): it is not ours to remove


def _atomic_write(path: Path, text: str) -> None:
    """Write ``text`` to ``path`` whole or not at all (:func:`coexist.files.atomic`)."""
    from .files import atomic

    with atomic(path) as tmp:
        tmp.write_text(text, encoding="utf-8")


def parts_folder(output) -> Path:
    """The parts folder of an output file: ``FILE.parts`` beside it.

    Parameters
    ----------
    output : str or pathlib.Path

    Returns
    -------
    pathlib.Path
    """
    p = Path(output)
    return p.with_name(p.name + ".parts")


# --- running ---------------------------------------------------------------------------------------------
def default_chunk_size(points: int, workers: int) -> int:
    """Points per chunk: about four chunks per worker (so a lost or slow chunk costs little), at most 16.

    Parameters
    ----------
    points, workers : int

    Returns
    -------
    int
    """
    return max(1, min(16, math.ceil(points / (4 * max(1, workers)))))


def run_sweep(
    spec: SweepSpec,
    *,
    workers: int = 1,
    client=None,
    parts_dir=None,
    resume: bool = False,
    chunk_size: int | None = None,
    evaluate: Callable | None = None,
    progress: Callable | None = None,
    max_retries: int = 3,
) -> SweepResult:
    """Compute every point of ``spec``: serially, on a local process pool or on a Dask cluster.

    Parameters
    ----------
    spec : SweepSpec
    workers : int
        1: in this process; more: a pool of that many ``spawn`` processes (ignored with ``client``).
    client : distributed.Client, optional
        Compute on this Dask cluster instead (one task per chunk; the scheduler moves a dead worker's
        tasks, and a chunk that still fails is submitted again).
    parts_dir : str or pathlib.Path, optional
        Write each finished chunk there (:class:`Parts`); None: keep everything in memory.
    resume : bool
        Read the chunks already in ``parts_dir`` (of the same sweep) and compute only the others.
    chunk_size : int, optional
        Points per chunk; default :func:`default_chunk_size` (a resumed sweep keeps its own).
    evaluate : callable, optional
        ``evaluate(spec, index) -> record``; default :func:`evaluate_point` (tests count or fail evaluations
        with their own; it must be importable by the workers).
    progress : callable, optional
        Called with the number of points just finished (also those read from parts).
    max_retries : int
        How often a chunk whose worker died is computed again before its points get the status ``lost``.

    Returns
    -------
    SweepResult

    Raises
    ------
    SceneError
        If ``parts_dir`` holds parts of another sweep, or parts exist and ``resume`` is False.
    """
    t0 = time.perf_counter()
    n_workers = 1 if client is None else _cluster_threads(client)
    if client is None:
        n_workers = max(1, int(workers))
    folder = Path(parts_dir) if parts_dir is not None else None
    if folder is not None:
        check_parts_folder(folder)
    manifest = Parts.read_manifest(folder) if folder is not None and folder.exists() else None
    if folder is not None and folder.exists() and any(folder.iterdir()) and not resume:
        raise SceneError(
            f"{folder} holds the parts of an interrupted sweep: resume it (--resume) or remove the folder",
            "--resume",
        )
    if manifest is not None:
        if manifest.get("fingerprint") != spec.fingerprint() or manifest.get("format") != PARTS_FORMAT:
            raise SceneError(
                f"{folder} holds the parts of a different sweep (other scene, keys, values or accuracy); "
                "remove the folder or write to another file",
                "--resume",
            )
        chunk_size = int(manifest["chunk_size"])
    chunk_size = int(chunk_size or default_chunk_size(spec.size, n_workers))
    chunks = {
        c: list(range(c * chunk_size, min(spec.size, (c + 1) * chunk_size)))
        for c in range(math.ceil(spec.size / chunk_size))
    }
    parts = Parts(folder, spec, chunk_size) if folder is not None else None
    done: dict = {}
    if parts is not None:
        if manifest is not None:
            for c, idx in chunks.items():
                records = parts.read(c, idx)
                if records is not None:
                    done[c] = records
        else:
            parts.create()
    reused = sum(len(r) for r in done.values())
    if progress is not None and reused:
        progress(reused)
    todo = {c: idx for c, idx in chunks.items() if c not in done}

    def store(c, records):
        if parts is not None:
            parts.write(c, records)
        done[c] = records
        if progress is not None:
            progress(len(records))

    retried = 0
    if not todo:
        executor = "none"
    elif client is not None:
        executor = "dask"
        retried = _run_dask(client, spec, todo, evaluate, store, max_retries)
    elif n_workers > 1 and len(todo) > 1:
        executor = "processes"
        retried = _run_pool(spec, todo, evaluate, store, min(n_workers, len(todo)), max_retries)
    else:
        executor = "serial"
        for c, idx in todo.items():
            store(c, _run_chunk(spec, idx, evaluate))
    records = [r for c in sorted(done) for r in done[c]]
    return SweepResult(
        spec,
        records,
        computed=spec.size - reused,
        reused=reused,
        retried_chunks=retried,
        seconds=time.perf_counter() - t0,
        workers=n_workers,
        executor=executor,
    )


def _lost(idx, attempts) -> list:
    return [failure_record(i, "lost", f"the worker computing it died {attempts} times") for i in idx]


def _run_pool(spec, todo, evaluate, store, workers, max_retries) -> int:
    """A local pool of ``spawn`` processes; a broken pool (a worker died) is replaced and its chunks resubmitted."""
    import concurrent.futures as cf
    import multiprocessing
    from concurrent.futures.process import BrokenProcessPool

    ctx = multiprocessing.get_context("spawn")
    pending = dict(todo)
    attempts = dict.fromkeys(pending, 0)
    retried = 0
    while pending:
        pool = cf.ProcessPoolExecutor(max_workers=min(workers, len(pending)), mp_context=ctx)
        try:
            futures = {pool.submit(_run_chunk, spec, idx, evaluate): c for c, idx in pending.items()}
            for fut in cf.as_completed(futures):
                c = futures[fut]
                try:
                    records = fut.result()
                except BrokenProcessPool:
                    continue
                store(c, records)
                del pending[c]
        finally:
            pool.shutdown(wait=True, cancel_futures=True)
        for c in list(pending):
            attempts[c] += 1
            retried += 1
            if attempts[c] > max_retries:
                store(c, _lost(pending.pop(c), attempts[c]))
    return retried


def _cluster_threads(client) -> int:
    try:
        return max(1, int(sum(client.nthreads().values())))
    except Exception:
        return 1


def _run_dask(client, spec, todo, evaluate, store, max_retries) -> int:
    """One Dask task per chunk; a chunk whose task fails (``KilledWorker``: its workers kept dying) is resubmitted."""
    from distributed import as_completed

    attempts = dict.fromkeys(todo, 0)
    retried = 0
    futures = {client.submit(_run_chunk, spec, idx, evaluate, pure=False): c for c, idx in todo.items()}
    queue = as_completed(list(futures))
    for fut in queue:
        c = futures.pop(fut)
        try:
            records = fut.result()
        except Exception:  # the task's workers died (KilledWorker) or the task was lost
            attempts[c] += 1
            retried += 1
            if attempts[c] > max_retries:
                store(c, _lost(todo[c], attempts[c]))
                continue
            new = client.submit(_run_chunk, spec, todo[c], evaluate, pure=False)
            futures[new] = c
            queue.add(new)
            continue
        store(c, records)
    return retried


def sweep(
    scene,
    vary,
    settings: SolverSettings | None = None,
    *,
    workers: int = 1,
    client=None,
    output=None,
    resume: bool = False,
    overwrite: bool = False,
    chunk_size: int | None = None,
    evaluate: Callable | None = None,
    progress: Callable | None = None,
) -> SweepResult:
    """Run the scene's ramp at every point of a grid of scene fields.

    Parameters
    ----------
    scene : Scene, str or pathlib.Path
        The base scene, or a built-in name or a path.
    vary : mapping or iterable
        The swept keys (:func:`make_axes`): ``{"chamber.closing_pressure_mbar": "19:21:5"}`` or
        ``["chamber.closing_pressure_mbar=19:21:5", "membrane.zone_radius_mm=21.2,21.4"]``.
    settings : SolverSettings, optional
        Default: :class:`SolverSettings`.
    workers : int
        Local processes (1: this process).
    client : distributed.Client, optional
        Compute on a Dask cluster instead.
    output : str or pathlib.Path, optional
        A netCDF file to write the result to (atomically, at the end); the finished chunks go to
        ``output.parts`` meanwhile (:func:`parts_folder`), which is removed once the file is written.
    resume : bool
        Continue an interrupted sweep from ``output.parts``.
    overwrite : bool
        Replace an existing ``output``.
    chunk_size : int, optional
        Points per chunk (:func:`default_chunk_size`).
    evaluate, progress : callable, optional
        See :func:`run_sweep`.

    Returns
    -------
    SweepResult

    Raises
    ------
    SceneError
        For a bad scene, key or value, an existing output without ``overwrite``, a parts folder of another
        sweep, or parts without ``resume``.

    Examples
    --------
    >>> from coexist.sweep import sweep  # doctest: +SKIP
    >>> res = sweep("tricircle", {"chamber.closing_pressure_mbar": [19.8, 20.0]}, workers=2)  # doctest: +SKIP
    >>> res.to_xarray()["spinodal_up_kV"].values  # doctest: +SKIP
    array([4.2348..., 3.9000...])
    """
    spec = make_spec(scene, vary, settings)
    if output is None:
        return run_sweep(
            spec, workers=workers, client=client, chunk_size=chunk_size, evaluate=evaluate, progress=progress
        )
    out = Path(output)
    if out.exists() and not overwrite:
        raise SceneError(f"{out} exists; pass overwrite=True (--overwrite) to replace it", "-o")
    folder = parts_folder(out)
    check_parts_folder(folder)
    if overwrite and not resume:
        remove_parts(folder)
    result = run_sweep(
        spec,
        workers=workers,
        client=client,
        parts_dir=folder,
        resume=resume,
        chunk_size=chunk_size,
        evaluate=evaluate,
        progress=progress,
    )
    result.to_netcdf(out)
    remove_parts(folder)
    return result


# --- the design map ------------------------------------------------------------------------------------
def plot_design_map(
    dataset,
    path,
    variable: str = "spinodal_up_kV",
    x: str | None = None,
    y: str | None = None,
    title: str | None = None,
) -> None:
    """A design map: ``variable`` over two swept keys (colour), hatched where breakdown comes before any zone
    bulges, grey with a cross where a point has no answer (status and reason in the dataset), dotted where the
    zones stay equal.

    Parameters
    ----------
    dataset : xarray.Dataset
        A sweep (:meth:`SweepResult.to_xarray`) with at least two swept keys of more than one value each, or
        one swept key (drawn as a curve).
    path : str or pathlib.Path
        The figure file (.png, .svg, .pdf).
    variable : str
        The per-point quantity to colour by.
    x, y : str, optional
        The dimensions on the axes; default the last two swept keys with more than one value.
    title : str, optional
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Patch, Rectangle

    swept = [d for d in dataset.attrs["swept_dims"].split(",") if dataset.sizes[d] > 1]
    if x is None or y is None:
        if len(swept) < 2:
            raise SceneError("a design map needs two swept keys with more than one value each", "--plot")
        y, x = (y or swept[-2]), (x or swept[-1])
    # the cells in the order of their values (--vary may list them in any order: unsorted centres misplaced cells)
    dataset = dataset.sortby([y, x])
    da = dataset[variable]
    st = dataset["status"]
    rest = {d: 0 for d in da.dims if d not in (x, y)}
    if rest:
        da, st = da.isel(rest), st.isel(rest)
    # the other swept keys: the map is the slice at their first value, and says so (review, helper-82)
    sliced = [f"{_axis_label(dataset[d], d)} = {dataset[d].values[0]}" for d in rest if dataset.sizes[d] > 1]
    da = da.transpose(y, x)
    st = st.transpose(y, x)
    (xs, x_names), (ys, y_names) = _map_positions(dataset[x].values), _map_positions(dataset[y].values)
    fig, ax = plt.subplots(figsize=(7.2, 5.8), layout="constrained")
    mesh = ax.pcolormesh(xs, ys, da.values, shading="nearest", cmap="viridis")
    unit = " (kV)" if variable.endswith("_kV") else ""  # closing_pressure_ratio is a ratio
    if np.isfinite(np.asarray(da.values, dtype=float)).any():
        fig.colorbar(mesh, ax=ax, label=f"{variable.removesuffix('_kV').replace('_', ' ')}{unit}")
    else:  # nothing to colour: no colour bar of an empty range, and the map says so (review, helper-83)
        where = (
            "in this slice" if np.isfinite(np.asarray(dataset[variable].values, dtype=float)).any() else "at any point"
        )
        ax.text(
            0.5,
            0.5,
            f"no {variable} {where} (the dataset's reason says why)",
            transform=ax.transAxes,
            ha="center",
            va="center",
            fontsize=9,
            bbox={"facecolor": "white", "edgecolor": "0.5"},
        )
    status = st.values.astype(str)
    xe, ye = _cell_edges(xs), _cell_edges(ys)
    handles: list = []
    styles = (
        ("breakdown_first", "///", "crimson", "breakdown before any zone bulges"),
        ("no_bulge", "..", "0.35", "no zone bulges up to the top"),
        ("leaves_range", "\\\\", "darkorange", "leaves the model's range first"),
    )
    for code, hatch, colour, label in styles:
        cells = np.argwhere(status == code)
        for iy, ix in cells:
            ax.add_patch(
                Rectangle(
                    (xe[ix], ye[iy]),
                    xe[ix + 1] - xe[ix],
                    ye[iy + 1] - ye[iy],
                    hatch=hatch,
                    facecolor="none",
                    edgecolor=colour,
                    linewidth=0,
                )
            )
        if len(cells):
            handles.append(Patch(hatch=hatch, facecolor="none", edgecolor=colour, label=label))
    failed = ~np.isin(status, ANSWERED)
    if failed.any():
        X, Y = np.meshgrid(xs, ys)
        ax.scatter(X[failed], Y[failed], marker="x", color="0.3", s=25)
        handles.append(plt.Line2D([], [], marker="x", ls="", color="0.3", label="no answer (status says why)"))
    if handles:
        fig.legend(handles=handles, loc="outside lower center", ncols=min(4, len(handles)), fontsize=8, frameon=False)
    ax.set_xlabel(_axis_label(dataset[x], x))
    ax.set_ylabel(_axis_label(dataset[y], y))
    # few values (e.g. zone counts 2 and 5): ticks at the values computed, not at ones in between
    for values, names, set_ticks in ((xs, x_names, ax.set_xticks), (ys, y_names, ax.set_yticks)):
        if names is not None:  # a text key (a material): one cell per value, named
            set_ticks(values, names)
        elif values.size <= MAP_TICKS_MAX:
            set_ticks(values, [f"{v:g}" for v in values])
    if title or sliced:
        ax.set_title("\n".join(filter(None, [title, ("at " + ", ".join(sliced)) if sliced else ""])), fontsize=9)
    fig.savefig(path, dpi=130)
    plt.close(fig)


#: a design map's axis with at most this many values has its ticks at exactly those values
MAP_TICKS_MAX = 12


def _map_positions(values) -> tuple:
    """Where a swept key's values sit on a design map's axis: the values themselves, or for text (a material)
    the positions ``0, 1, …`` with the values as names (None for numbers)."""
    try:
        return np.asarray(values, dtype=float), None
    except (TypeError, ValueError):
        return np.arange(len(values), dtype=float), [str(v) for v in values]


def _cell_edges(centres: np.ndarray) -> np.ndarray:
    """Edges of the cells around sorted or unsorted centres (midpoints; half a step beyond the ends)."""
    c = np.asarray(centres, dtype=float)
    if c.size == 1:
        return np.array([c[0] - 0.5, c[0] + 0.5])
    mid = 0.5 * (c[1:] + c[:-1])
    return np.concatenate([[c[0] - (mid[0] - c[0])], mid, [c[-1] + (c[-1] - mid[-1])]])


def _axis_label(coord, dim: str) -> str:
    key = coord.attrs.get("scene_key", dim)
    section, _, rest = key.partition(".")
    return f"[{section}].{rest}" if rest else key
