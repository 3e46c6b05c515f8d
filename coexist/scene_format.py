"""The scene file format: sections, keys, unit suffixes, defaults and the checks on every value.

:func:`read_document` turns a parsed TOML document into plain keyword arguments of
:class:`coexist.scene.Scene` (SI units), raising :class:`SceneError` naming the field
(``[chamber].volume_ml``) for the first problem found. Every dimensional value carries its unit in
its key name (``thickness_mm = 0.5``, never ``thickness = 0.5``).

Sections and keys (defaults in brackets; ``*`` marks a key that takes a unit suffix):

============  ===========================================================================================
[membrane]    ``material`` ("neo-hookean" or "gent"), ``jlim`` (gent only), ``shear_modulus_*``,
              ``relative_permittivity``, ``thickness_*``, ``zone_radius_*`` (all required);
              ``prestretch`` [1, no prestretch], ``breakdown_field_*`` [absent: no breakdown check],
              ``wrinkling`` ["refuse": a state with a compressive hoop tension is no state; or
              "tension-field": it wrinkles and carries the relaxed energy, coexist.wrinkling]
[zones]       ``count`` (required), a whole number 1..1000: identical zones sharing one gas and one voltage;
              ``pressure_*``: the gauge pressure held directly when there is no [chamber]
[chamber]     ``volume_*`` (required), ``closing_pressure_*`` (required, gauge),
              ``atmospheric_pressure_*`` [101.325 kPa], at most 1 GPa (:data:`MAX_ATMOSPHERIC_PRESSURE`) and
              normalised ``Patm A/(μH)`` at most 1e10 (:data:`MAX_ATMOSPHERIC_PRESSURE_HAT`);
              absent: the pressure is controlled directly
[voltage]     a ramp ``start_*`` [0], ``stop_*`` (required), ``step_*`` [(stop − start)/100], which goes
              up from start to stop and back down to start; or a list ``values_*``; absent: no voltage
[electrodes]  ``pattern`` ["full": the electrode covers the whole zone; "inner-circle": a disc of radius
              ``inner_fraction`` · zone radius at the centre; "ring": the annulus from ``inner_fraction`` to
              ``outer_fraction`` · zone radius], radius fractions of the reference state, inner in (0, 1),
              outer in (inner, 1]; absent: "full". Patterned zones (coexist.patterned) are computed by
              every command: ``curves``, ``ramp``, ``coexistence``, ``shape``, ``fit`` and ``sweep``
[layers]      ``passive`` [1]: layers (whole number 1..100) of the regions without electrode, whose stack
              is that many times the membrane; the electrode regions are one layer; only with a pattern
              that has such regions ("inner-circle", "ring"); or ``regions``: one whole number per region
              of the pattern, from the pole out (inner-circle 2, ring 3, or 2 when it reaches the clamp),
              e.g. [1, 2]; not both
[fitted]      free-form notes of fitted parameters, carried through unchanged
top level     ``name``, ``description``
============  ===========================================================================================

A scene holds no solver settings: how accurately it is solved is a choice of the run
(:class:`~coexist.settings.SolverSettings`; ``--accuracy`` / ``--rtol`` on the command line).

Unit suffixes (:data:`UNITS`): length ``_m _mm _um``; shear modulus ``_Pa _kPa _MPa``; pressure
``_Pa _kPa _mbar _bar``; volume ``_m3 _l _ml``; voltage ``_V _kV``; field ``_V_per_m _MV_per_m``.
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from .effects import MATERIALS, canonical_material
from .errors import SceneError

MAX_ZONES = 1000
#: most layers of a passive region (equal to :data:`coexist.patterned.MAX_LAYERS`, tested; not imported here
#: so that reading a scene does not import the solver)
MAX_LAYERS = 100
#: the electrode patterns of ``[electrodes] pattern`` (:class:`coexist.patterned.ZonePattern`)
PATTERNS = ("full", "inner-circle", "ring")
MAX_VOLTAGE_POINTS = 100_000
#: Dimensional values must lie in this range in SI units (keeps every scale finite and non-zero).
SI_RANGE = (1e-30, 1e30)
#: The highest atmospheric pressure in Pa (1 GPa): ten times the pressure at the bottom of the deepest ocean, where
#: soft dielectric elastomer robots have been run, and far above where any gas is the chamber's ideal gas. (What limits
#: the solver is the normalised ``p̂atm``, :data:`MAX_ATMOSPHERIC_PRESSURE_HAT`: helper-98 measured the tricircle's
#: equal-free-energy voltage losing digits above 1 GPa and its gradient flow stalling at 1e9 kPa, ``p̂atm`` ≈ 1e9;
#: helper-102 removed both causes, the gas's free energy evaluated with cancellation and a flow tolerance below the
#: gas pressure's rounding.)
MAX_ATMOSPHERIC_PRESSURE = 1e9
#: The highest normalised atmospheric pressure ``p̂atm = Patm A/(μH)``: the gas's stiffness grows with it (the chamber
#: then holds the zones' total volume nearly fixed) and the gas pressure's rounding, ``~1e-16 p̂atm``, with it. A very
#: soft, thin membrane reaches it at one atmosphere (``μ`` = 1 Pa, ``H`` = 1 µm, ``A`` = 0.1 m gives 1e10). Every
#: command was checked to 1e11 on the built-in scenes and variations of the tricircle (zones 2, 3, 7; chamber 1 ml to
#: 100 l; draft to high accuracy; patterned zones): the same normalised results as at 1e8 within their errors; at 1e12
#: the jump's gradient flow of the tricircle's 7 zones, or of its zones on a 1 ml chamber, no longer lands
#: (helper-102).
MAX_ATMOSPHERIC_PRESSURE_HAT = 1e10

#: Accepted unit suffixes per kind of quantity, with their factor to SI.
UNITS = {
    "length": {"m": 1.0, "mm": 1e-3, "um": 1e-6},
    "modulus": {"Pa": 1.0, "kPa": 1e3, "MPa": 1e6},
    "pressure": {"Pa": 1.0, "kPa": 1e3, "mbar": 1e2, "bar": 1e5},
    "volume": {"m3": 1.0, "l": 1e-3, "ml": 1e-6},
    "voltage": {"V": 1.0, "kV": 1e3},
    "field": {"V_per_m": 1.0, "MV_per_m": 1e6},
}
#: Defaults in SI units of the keys a scene may leave out: only those with a standard value. The physical
#: properties of the membrane (shear modulus, thickness, zone radius, the permittivity when there is a
#: voltage, Jlim of a Gent material) and the number of zones are required: a scene never runs on a
#: value it did not state. ``coexist check`` lists every defaulted value.
DEFAULTS: dict[str, Any] = {
    "prestretch": 1.0,
    "wrinkling": "refuse",
    "atmospheric_pressure": 101_325.0,
    "start": 0.0,
}


@dataclass(frozen=True)
class _Key:
    """One scene key: its kind (a key of UNITS, or number/integer/string) and its rule."""

    kind: str
    rule: str = ""  # "positive", "nonnegative", "at_least_one"
    unit: str = ""  # the unit used in examples
    many: bool = False  # a list of values


SCHEMA = {
    "membrane": {
        "material": _Key("string"),
        "jlim": _Key("number", "positive"),
        "shear_modulus": _Key("modulus", "positive", "kPa"),
        "relative_permittivity": _Key("number", "at_least_one"),
        "thickness": _Key("length", "positive", "mm"),
        "zone_radius": _Key("length", "positive", "mm"),
        "prestretch": _Key("number", "at_least_one"),
        "breakdown_field": _Key("field", "positive", "MV_per_m"),
        "wrinkling": _Key("string"),
    },
    "zones": {"count": _Key("integer"), "pressure": _Key("pressure", "positive", "mbar")},
    "chamber": {
        "volume": _Key("volume", "positive", "ml"),
        "closing_pressure": _Key("pressure", "positive", "mbar"),
        "atmospheric_pressure": _Key("pressure", "positive", "kPa"),
    },
    "voltage": {
        "start": _Key("voltage", "nonnegative", "kV"),
        "stop": _Key("voltage", "nonnegative", "kV"),
        "step": _Key("voltage", "positive", "kV"),
        "values": _Key("voltage", "nonnegative", "kV", many=True),
    },
    "electrodes": {
        "pattern": _Key("string"),
        "inner_fraction": _Key("number", "open_fraction"),
        "outer_fraction": _Key("number", "fraction"),
    },
    "layers": {"passive": _Key("integer"), "regions": _Key("integer", many=True)},
}
TOP_LEVEL = ("name", "description", "fitted", *SCHEMA)
_RULES = {
    "positive": (lambda x: x > 0, "positive"),
    "nonnegative": (lambda x: x >= 0, "zero or positive"),
    "at_least_one": (lambda x: x >= 1, "at least 1"),
    "open_fraction": (lambda x: 0 < x < 1, "a fraction strictly between 0 and 1"),
    "fraction": (lambda x: 0 < x <= 1, "a fraction above 0 and at most 1"),
}


def _key_names(section: str) -> list[str]:
    """Every valid key of a section, each unit suffix spelled out."""
    names = []
    for name, key in SCHEMA[section].items():
        names += [f"{name}_{u}" for u in UNITS[key.kind]] if key.kind in UNITS else [name]
    return names


def did_you_mean(word: str, options) -> str:
    """``"; did you mean 'x'?"`` for the closest option (same spelling in another case first), or ``""``.

    Parameters
    ----------
    word : str
        The unknown word as written.
    options : iterable of str
        The valid words.

    Returns
    -------
    str
        The hint to append to an error message, or ``""`` when no option is close
        (:func:`difflib.get_close_matches`, default cutoff).
    """
    options = list(options)
    same_case = {o.lower(): o for o in options}
    import difflib  # only a misspelt key needs it

    match = [same_case[word.lower()]] if word.lower() in same_case else difflib.get_close_matches(word, options, 1)
    return f"; did you mean {match[0]!r}?" if match else ""


def _describe(value) -> str:
    if isinstance(value, bool):
        return f"the boolean {str(value).lower()}"
    if isinstance(value, str):
        return f"the string {value!r}"
    if isinstance(value, dict):
        return "a table"
    if isinstance(value, list):
        return "a list"
    return f"{type(value).__name__} {value!r}"


def _resolve(section: str, key: str) -> tuple[str, str]:
    """``"thickness_mm"`` -> ``("thickness", "mm")``; unknown keys and units are SceneErrors."""
    where = f"[{section}].{key}"
    spec = SCHEMA[section]
    if key in spec:
        if spec[key].kind in UNITS:
            units = ", ".join(f"_{u}" for u in UNITS[spec[key].kind])
            raise SceneError(f"put the unit in the key, e.g. {key}_{spec[key].unit} (units: {units})", where)
        return key, ""
    for name, spec_key in spec.items():
        if spec_key.kind in UNITS and key.startswith(name + "_"):
            unit = key[len(name) + 1 :]
            if unit in UNITS[spec_key.kind]:
                return name, unit
            units = ", ".join(f"_{u}" for u in UNITS[spec_key.kind])
            hint = did_you_mean(key, [f"{name}_{u}" for u in UNITS[spec_key.kind]])
            raise SceneError(f"unknown unit '_{unit}' for {name}{hint} (units: {units})", where)
    hint = did_you_mean(key, _key_names(section)) or f"; valid keys: {', '.join(_key_names(section))}"
    raise SceneError(f"unknown key in [{section}]{hint}", where)


def _value(key: _Key, value, unit: str, where: str):
    """Check a value against its key and convert it to SI units."""
    if key.many:
        if not isinstance(value, list) or not value:
            raise SceneError(f"expected a non-empty list of numbers, got {_describe(value)}", where)
        if len(value) > MAX_VOLTAGE_POINTS:
            raise SceneError(f"at most {MAX_VOLTAGE_POINTS} values, got {len(value)}", where)
        return [_value(replace(key, many=False), v, unit, where) for v in value]
    if key.kind == "string":
        if not isinstance(value, str):
            raise SceneError(f"expected a string, got {_describe(value)}", where)
        return value
    if key.kind == "integer":
        if isinstance(value, bool) or not isinstance(value, int):
            raise SceneError(f"expected a whole number, got {_describe(value)}", where)
        return value
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        quoted = " (write numbers without quotes)" if isinstance(value, str) else ""
        raise SceneError(f"expected a number, got {_describe(value)}{quoted}", where)
    shown = f"{value!r}{' ' + unit if unit else ''}"
    x = float(value)
    if not math.isfinite(x):
        raise SceneError(f"must be a finite number, got {shown}", where)
    if key.rule:
        ok, words = _RULES[key.rule]
        if not ok(x):
            raise SceneError(f"must be {words}, got {shown}", where)
    x *= UNITS[key.kind][unit] if unit else 1.0
    if x != 0 and not SI_RANGE[0] <= abs(x) <= SI_RANGE[1]:
        raise SceneError(f"{shown} is out of range (at most 1e30 and at least 1e-30 in SI units)", where)
    return x


class _Section:
    """The checked entries of one section: ``{name: (key as written, value in SI units)}``."""

    def __init__(self, doc: dict, section: str):
        self.section = section
        self.present = section in doc
        table = doc.get(section, {})
        if not isinstance(table, dict):
            raise SceneError(f"must be a table (a [{section}] header), got {_describe(table)}", f"[{section}]")
        self.entries: dict = {}
        for key, value in table.items():
            name, unit = _resolve(section, key)
            if name in self.entries:
                raise SceneError(f"{name} given twice (as {self.entries[name][0]} and {key})", self.where(name, key))
            self.entries[name] = (key, _value(SCHEMA[section][name], value, unit, self.where(name, key)))

    def __contains__(self, name):
        return name in self.entries

    def get(self, name, default=None):
        return self.entries[name][1] if name in self.entries else default

    def where(self, name, key=None):
        """``[section].key`` as written, or with the example unit if the key is absent."""
        if key is None:
            spec = SCHEMA[self.section][name]
            key = self.entries[name][0] if name in self.entries else name + (f"_{spec.unit}" if spec.unit else "")
        return f"[{self.section}].{key}"

    def require(self, name, what):
        if name not in self.entries:
            spec = SCHEMA[self.section][name]
            example = f"{name}_{spec.unit}" if spec.unit else name
            raise SceneError(f"missing: {what}, e.g. {example} = ...", self.where(name))
        return self.get(name)


def read_document(doc: dict, source: str) -> dict:
    """Check a parsed TOML scene and return the keyword arguments of :class:`~coexist.scene.Scene`.

    ``chamber`` and ``voltage`` are plain dicts (or ``None``); values are in SI units.

    Parameters
    ----------
    doc : dict
        The parsed TOML document (``tomllib.loads``).
    source : str
        Where it came from; its stem is the scene's ``name`` when the document gives none.

    Returns
    -------
    dict
        Keyword arguments of :class:`~coexist.scene.Scene`, defaults filled in; ``voltage`` holds the
        path's ``values`` in V (:func:`ramp_path` for a ramp), ``fitted`` a deep copy of ``[fitted]``.

    Raises
    ------
    SceneError
        For the first problem found, naming the field: e.g. an unknown section or key (the closest name
        suggested), a ``[solver]`` section, a missing unit or required key, a value of the wrong type, sign
        or range, or an inconsistent combination (a membrane not thinner than its zone radius, a prestretch
        that locks the Gent chains, both a chamber and a controlled pressure, a ramp going down).
    """
    for key in doc:
        if key == "solver":
            raise SceneError(
                "a scene describes the experiment only: the solver's tolerance is a choice of the run "
                "(--accuracy draft|default|high or --rtol X on the command line, SolverSettings in Python)",
                "[solver]",
            )
        if key not in TOP_LEVEL:
            table = isinstance(doc[key], dict)
            raise SceneError(_unknown_top_level(key, table), f"[{key}]" if table else key)
    name, description = (_top_string(doc, k) for k in ("name", "description"))
    fitted = doc.get("fitted", {})
    if not isinstance(fitted, dict):
        raise SceneError(f"must be a table (a [fitted] header), got {_describe(fitted)}", "[fitted]")
    if not any(s in doc for s in SCHEMA):
        raise SceneError(
            "the scene is empty: it needs at least [membrane] (material, shear_modulus_kPa, thickness_mm, "
            "zone_radius_mm) and [zones] count",
            "[membrane]",
        )
    sections = {s: _Section(doc, s) for s in SCHEMA}
    membrane, zones, chamber, voltage = (sections[s] for s in ("membrane", "zones", "chamber", "voltage"))
    defaulted: list[str] = []

    def optional(section: _Section, key: str, default=None):
        if key in section:
            return section.get(key)
        if default is not None:
            defaulted.append(f"[{section.section}].{key}")
        return default

    material, jlim = _material(membrane)
    shear_modulus = membrane.require("shear_modulus", "the shear modulus μ of the elastomer")
    thickness = membrane.require("thickness", "the membrane's thickness H")
    radius = membrane.require("zone_radius", "the radius A of each clamped zone")
    permittivity = membrane.require("relative_permittivity", "the relative permittivity εr of the elastomer")
    if not thickness < radius:
        raise SceneError(
            f"a membrane must be thinner than its zone radius ({radius * 1e3:g} mm), got {thickness * 1e3:g} mm",
            membrane.where("thickness"),
        )
    prestretch = optional(membrane, "prestretch", DEFAULTS["prestretch"])
    if jlim is not None and 2 * prestretch**2 + prestretch**-4 - 3 >= jlim:
        raise SceneError(
            f"a prestretch of {prestretch:g} locks a Gent membrane with jlim = {jlim:g}", membrane.where("prestretch")
        )
    wrinkling = optional(membrane, "wrinkling", DEFAULTS["wrinkling"])
    from .model import WRINKLING_MODES

    if wrinkling not in WRINKLING_MODES:
        raise SceneError(
            f"must be one of {', '.join(map(repr, WRINKLING_MODES))}, got {wrinkling!r}"
            f"{did_you_mean(str(wrinkling), WRINKLING_MODES)}",
            membrane.where("wrinkling"),
        )
    count = zones.require("count", "the number of identical zones")
    if not 1 <= count <= MAX_ZONES:
        raise SceneError(f"must be a whole number from 1 to {MAX_ZONES}, got {count}", zones.where("count"))
    pressure = zones.get("pressure")
    if pressure is not None and chamber.present:
        raise SceneError(
            "the chamber's gas sets the pressure: give either [chamber] or a controlled pressure, not both",
            zones.where("pressure"),
        )
    chamber_fields, voltage_fields = _chamber(chamber, optional), _voltage(voltage, optional)
    if chamber_fields is not None:
        patm_hat = chamber_fields["atmospheric_pressure"] * radius / (shear_modulus * thickness)
        if patm_hat > MAX_ATMOSPHERIC_PRESSURE_HAT:
            raise SceneError(
                f"the normalised atmospheric pressure p̂atm = Patm·A/(μH) = {patm_hat:.3g} is above "
                f"{MAX_ATMOSPHERIC_PRESSURE_HAT:g}, where the gas is too stiff to solve for (a membrane of μ = "
                f"{shear_modulus:g} Pa, H = {thickness * 1e6:g} µm and A = {radius * 1e3:g} mm under "
                f"{chamber_fields['atmospheric_pressure'] / 1e3:g} kPa): a stiffer or thicker membrane, a smaller "
                "zone, or a lower atmospheric pressure",
                chamber.where("atmospheric_pressure"),
            )
    pattern = _pattern(sections["electrodes"], sections["layers"])
    return dict(
        shear_modulus=shear_modulus,
        relative_permittivity=permittivity,
        thickness=thickness,
        zone_radius=radius,
        prestretch=prestretch,
        wrinkling=wrinkling,
        material=material,
        jlim=jlim,
        breakdown_field=membrane.get("breakdown_field"),
        zone_count=count,
        controlled_pressure=pressure,
        controlled_pressure_field=zones.where("pressure"),
        chamber=chamber_fields,
        voltage=voltage_fields,
        **pattern,
        name=name if name is not None else Path(source).stem,
        description=description or "",
        fitted=copy.deepcopy(fitted),
        source=source,
        defaulted=tuple(defaulted),
    )


def _all_keys() -> dict[str, str]:
    return {k: s for s in SCHEMA for k in _key_names(s)}


def _unknown_top_level(key: str, table: bool) -> str:
    sections = [f"[{s}]" for s in (*SCHEMA, "fitted")]
    if table:
        return f"unknown section{did_you_mean(f'[{key}]', sections) or '; sections: ' + ', '.join(sections)}"
    if key in _all_keys():
        return f"belongs in a section: write it under [{_all_keys()[key]}]"
    for section in SCHEMA:
        try:
            _resolve(section, key)
        except SceneError:
            continue
        return f"belongs in a section: write it under [{section}]"
    hint = did_you_mean(key, ["name", "description"]) or "; top-level keys: name, description; sections: " + ", ".join(
        sections
    )
    return f"unknown key{hint}"


def _top_string(doc, key):
    value = doc.get(key)
    if value is not None and not isinstance(value, str):
        raise SceneError(f"expected a string, got {_describe(value)}", key)
    return value


def _material(membrane: _Section) -> tuple[str, float | None]:
    given = membrane.require("material", 'the elastomer model, "neo-hookean" or "gent"')
    material = canonical_material(given)
    if material is None:
        raise SceneError(
            f"unknown material {given!r}{did_you_mean(given.strip().lower(), MATERIALS)}; use one of "
            f"{', '.join(MATERIALS)}",
            membrane.where("material"),
        )
    if material != "gent":
        if "jlim" in membrane:
            raise SceneError('only the gent material takes jlim (add material = "gent")', membrane.where("jlim"))
        return material, None
    return material, membrane.require("jlim", "the Gent limit Jlim of I1 − 3 (e.g. 97 for VHB)")


def _chamber(chamber: _Section, optional) -> dict | None:
    if not chamber.present:
        return None
    atmospheric = optional(chamber, "atmospheric_pressure", DEFAULTS["atmospheric_pressure"])
    if atmospheric > MAX_ATMOSPHERIC_PRESSURE:
        raise SceneError(
            f"must be at most {MAX_ATMOSPHERIC_PRESSURE / 1e3:g} kPa (1 GPa, ten times the pressure at the bottom of "
            f"the deepest ocean; no gas is the chamber's ideal gas there), got {atmospheric / 1e3:g} kPa",
            chamber.where("atmospheric_pressure"),
        )
    return dict(
        volume=chamber.require("volume", "the chamber volume"),
        closing_pressure=chamber.require("closing_pressure", "the gauge pressure when the valves close"),
        atmospheric_pressure=atmospheric,
        closing_pressure_field=chamber.where("closing_pressure"),
    )


def _pattern(electrodes: _Section, layers: _Section) -> dict:
    """``[electrodes]`` and ``[layers]`` as the Scene's pattern fields (:func:`pattern_fields`); a present
    ``[electrodes]`` needs its ``pattern``, a present ``[layers]`` its ``passive``."""

    def where(name):
        return layers.where(name) if name in ("passive", "regions") else electrodes.where(name)

    if "regions" in layers and "passive" in layers:
        raise SceneError(
            "give either the passive regions' layers (passive) or every region's (regions), not both",
            layers.where("regions"),
        )
    passive = (
        layers.require("passive", "the number of layers of the regions without electrode (or regions = [1, 2])")
        if layers.present and "regions" not in layers
        else 1
    )
    return pattern_fields(
        electrodes.get("pattern"),
        electrodes.get("inner_fraction"),
        electrodes.get("outer_fraction"),
        passive,
        where,
        pattern_required=electrodes.present,
        region_layers=layers.get("regions"),
    )


def region_count(pattern: str, outer_fraction=None) -> int:
    """The number of concentric regions of a zone with this electrode pattern (:class:`~coexist.patterned.ZonePattern`):
    ``"full"`` 1, ``"inner-circle"`` 2 (disc and annulus), ``"ring"`` 3 (passive inside, ring, passive outside) or 2
    when the ring reaches the clamp (``outer_fraction = 1``).

    Parameters
    ----------
    pattern : str
        One of :data:`PATTERNS`.
    outer_fraction : float or None
        The ring's outer edge.

    Returns
    -------
    int
    """
    if pattern == "full":
        return 1
    if pattern == "ring" and outer_fraction is not None and outer_fraction < 1:
        return 3
    return 2


def pattern_fields(
    pattern,
    inner_fraction,
    outer_fraction,
    passive,
    where,
    pattern_required: bool = False,
    region_layers=None,
) -> dict:
    """Check an electrode pattern and return the :class:`~coexist.scene.Scene` fields that describe it.

    ``"full"``: the electrode covers the zone (no fraction, one layer); ``"inner-circle"``: an electrode disc of
    radius ``inner_fraction · A``, ``0 < inner_fraction < 1``; ``"ring"``: an electrode annulus from
    ``inner_fraction · A`` to ``outer_fraction · A``, ``0 < inner_fraction < outer_fraction ≤ 1`` (radii of
    the reference state). ``passive``: the layers of the regions without electrode, a whole number
    ``1..MAX_LAYERS``, other than 1 only when there are such regions. ``region_layers``: instead, the layers of
    every region from the pole out, one whole number ``1..MAX_LAYERS`` per region (:func:`region_count`).

    Parameters
    ----------
    pattern : str or None
        One of :data:`PATTERNS`; None: not given (``"full"``, unless ``pattern_required``).
    inner_fraction, outer_fraction : float or None
        The edges' radius fractions; None: not given.
    passive : int
        Layers of the passive regions.
    where : callable
        ``where(name)`` names the field or option of ``"pattern"``, ``"inner_fraction"``,
        ``"outer_fraction"`` or ``"passive"`` in messages (``[electrodes].inner_fraction``, ``--inner-fraction``).
    pattern_required : bool
        Whether a missing pattern is an error (a present ``[electrodes]`` section).
    region_layers : sequence of int, optional
        Every region's layers (``[layers] regions``; ``where("regions")`` names it); None: the electrode
        regions one layer, the passive ones ``passive``.

    Returns
    -------
    dict
        ``electrode_pattern``, ``inner_fraction``, ``outer_fraction`` (None where the pattern has no such
        edge), ``passive_layers`` and ``region_layers`` (a tuple, or None).

    Raises
    ------
    SceneError
        Naming the field: an unknown pattern (the closest suggested), a fraction the pattern does not take,
        a missing or out-of-range fraction, a ring whose outer edge is not outside its inner edge, a layer
        count that is not a whole number in ``1..MAX_LAYERS``, passive layers without a passive region.
    """
    if pattern is not None and pattern not in PATTERNS:
        raise SceneError(
            f"unknown pattern {pattern!r}{did_you_mean(str(pattern).strip(), PATTERNS)}; use one of "
            + ", ".join(f'"{p}"' for p in PATTERNS),
            where("pattern"),
        )
    uses = {"inner_fraction": ("inner-circle", "ring"), "outer_fraction": ("ring",)}
    given = {"inner_fraction": inner_fraction, "outer_fraction": outer_fraction}
    for name, patterns in uses.items():
        if given[name] is not None and pattern not in patterns:
            shown = " and ".join(f'"{p}"' for p in patterns)
            takes = "patterns take" if len(patterns) > 1 else "pattern takes"
            got = f'the pattern is "{pattern}"' if pattern is not None else "no pattern is given"
            raise SceneError(f"only the {shown} {takes} {name} ({got})", where(name))
    if pattern is None and pattern_required:
        raise SceneError('missing: the electrode pattern, "full", "inner-circle" or "ring"', where("pattern"))
    pattern = pattern or "full"
    inner = outer = None
    for name in uses:
        value = given[name]
        if pattern in uses[name] and value is None:
            what = {
                "inner-circle": "the electrode disc's radius",
                "ring": "the ring's inner radius" if name == "inner_fraction" else "the ring's outer radius",
            }[pattern]
            raise SceneError(
                f'missing: the "{pattern}" pattern needs {what} over the zone radius (reference state)', where(name)
            )
        if value is None:
            continue
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise SceneError(f"expected a finite number, got {_describe(value)}", where(name))
        rule = "open_fraction" if name == "inner_fraction" else "fraction"
        ok, words = _RULES[rule]
        if not ok(value):
            hint = (
                ' (a disc over the whole zone is the "full" pattern)'
                if pattern == "inner-circle" and value == 1
                else ""
            )
            raise SceneError(f"must be {words}, got {value!r}{hint}", where(name))
    if pattern in uses["inner_fraction"]:
        inner = float(given["inner_fraction"])
    if pattern == "ring" and inner is not None:
        outer = float(given["outer_fraction"])
        if not outer > inner:
            raise SceneError(
                f"the ring's outer edge must lie outside its inner edge (inner_fraction = {inner:g}), got {outer:g}",
                where("outer_fraction"),
            )
    if isinstance(passive, bool) or not isinstance(passive, int) or not 1 <= passive <= MAX_LAYERS:
        raise SceneError(f"must be a whole number from 1 to {MAX_LAYERS}, got {passive!r}", where("passive"))
    if passive != 1 and pattern == "full":
        raise SceneError(
            'the "full" electrode pattern has no region without electrode, so no passive layers (patterns with '
            'such regions: "inner-circle", "ring"; a thicker membrane is a larger thickness)',
            where("passive"),
        )
    regions = None
    if region_layers is not None:
        if passive != 1:
            raise SceneError("give either the passive regions' layers or every region's, not both", where("regions"))
        values = list(region_layers) if isinstance(region_layers, (list, tuple)) else None
        if not values:
            raise SceneError(f"expected a non-empty list of whole numbers, got {region_layers!r}", where("regions"))
        for v in values:
            if isinstance(v, bool) or not isinstance(v, int) or not 1 <= v <= MAX_LAYERS:
                raise SceneError(
                    f"every region's layers must be a whole number from 1 to {MAX_LAYERS}, got {v!r}", where("regions")
                )
        count = region_count(pattern, outer)
        if len(values) != count:
            raise SceneError(
                f'the "{pattern}" pattern has {count} region{"s" if count != 1 else ""} (from the pole out), got '
                f"{len(values)} layer counts",
                where("regions"),
            )
        if pattern == "full" and values != [1]:
            raise SceneError(
                'the "full" electrode pattern is one region of one layer (a thicker membrane is a larger thickness)',
                where("regions"),
            )
        regions = tuple(values)
    return dict(
        electrode_pattern=pattern,
        inner_fraction=inner,
        outer_fraction=outer,
        passive_layers=passive,
        region_layers=regions,
    )


def _voltage(voltage: _Section, optional) -> dict | None:
    if not voltage.present:
        return None
    ramp = [n for n in ("start", "stop", "step") if n in voltage]
    if "values" in voltage:
        if ramp:
            raise SceneError(
                "give either a ramp (start, stop, step) or a list of values, not both", voltage.where(ramp[0])
            )
        return dict(kind="list", values=np.array(voltage.get("values")))
    start = optional(voltage, "start", DEFAULTS["start"])
    stop = voltage.require("stop", "a ramp needs the highest voltage (or give a list of values)")
    if stop < start:
        raise SceneError(f"the ramp must go up: stop ({stop:g} V) is below start ({start:g} V)", voltage.where("stop"))
    step = voltage.get("step") if "step" in voltage else optional(voltage, "step", (stop - start) / 100 or 1.0)
    if (stop - start) / step > MAX_VOLTAGE_POINTS:
        raise SceneError(
            f"a step of {step:g} V makes {(stop - start) / step:.3g} steps; at most {MAX_VOLTAGE_POINTS}",
            voltage.where("step"),
        )
    return dict(kind="ramp", values=ramp_path(start, stop, step), start=start, stop=stop, step=step)


def ramp_path(start: float, stop: float, step: float) -> np.ndarray:
    """``start, start + step, ..., stop, ..., start + step, start``: up to ``stop`` and back down.

    The last step up is shortened to land on ``stop`` when ``stop − start`` is not a whole number of
    steps (to within 1e-9 of a step).

    Parameters
    ----------
    start, stop, step : float
        First and highest value and the step (any consistent unit; ``step > 0``, ``stop ≥ start``).

    Returns
    -------
    numpy.ndarray
        The path up and back down, shape ``(2m + 1,)`` with ``m + 1`` values from ``start`` to ``stop``.
    """
    steps = (stop - start) / step
    n = round(steps) if abs(steps - round(steps)) < 1e-9 * max(1.0, steps) else math.floor(steps)
    up = start + step * np.arange(n + 1)
    up = np.append(up[up < stop - 1e-9 * step], stop)
    return np.concatenate([up, up[-2::-1]])
