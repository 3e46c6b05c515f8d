"""Scenes: a physical experiment described in TOML, validated up front, in SI units and normalised.

A scene says what membrane is clamped over how many zones, on what gas chamber, along which voltage
path, and how accurately to solve. Every dimensional value carries its unit in its key name::

    [membrane]
    thickness_mm = 0.5          # not `thickness = 0.5`
    zone_radius_mm = 12

    [chamber]
    volume_ml = 300
    closing_pressure_mbar = 20  # gauge pressure when the valves close, at zero voltage

The sections, keys, unit suffixes and defaults are listed in :mod:`coexist.scene_format`.

Normalisation (seed eqs. 3–4, docs/physics.md), with ``μ`` the shear modulus, ``H`` the thickness, ``A``
the zone radius and ``ε = εr ε0`` the permittivity, all of the unstretched membrane::

    p̂ = p A/(μH)     V̂ = V/A³     Φ̂ = (Φ/H) √(ε/μ)     Q̂ = Q/(A² √(εμ))     Ψ̂ = Ψ/(μ H A²)

so that ``dΨ̂ = p̂ dV̂ − Q̂ dΦ̂``; a true field normalises as ``Ê = E √(ε/μ)``.
"""

from __future__ import annotations

import datetime
import functools
import math
import sys
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .errors import SceneError, told_apart
from .scene_format import DEFAULTS, PATTERNS, did_you_mean, read_document

if sys.version_info >= (3, 11):
    import tomllib
else:  # Python 3.10
    import tomli as tomllib

#: Vacuum permittivity ε0 in F/m (CODATA 2018).
VACUUM_PERMITTIVITY = 8.8541878128e-12
#: The scene ``load_scene(None)`` returns: the paper's experiment.
DEFAULT_SCENE = "tricircle"


# --- the scene -------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Chamber:
    """A rigid gas chamber under the zones, closed at a known gauge pressure (seed eq. 1).

    Attributes
    ----------
    volume : float
        Chamber volume ``Vc`` in m³ (without the zones).
    closing_pressure : float
        Gauge pressure ``p`` in Pa when the valves close, at zero voltage.
    atmospheric_pressure : float
        ``Patm`` in Pa, at most 1 GPa (:data:`~coexist.scene_format.MAX_ATMOSPHERIC_PRESSURE`); the gas obeys
        ``(Vc + Σ Vi)(Patm + p) = NkT``.
    """

    volume: float
    closing_pressure: float
    atmospheric_pressure: float = DEFAULTS["atmospheric_pressure"]
    closing_pressure_field: str = field(default="[chamber].closing_pressure_mbar", repr=False, compare=False)


@dataclass(frozen=True, eq=False)
class VoltagePath:
    """The voltages applied to all zones, in order.

    Attributes
    ----------
    kind : str
        ``"ramp"`` (up from ``start`` to ``stop`` in steps of ``step``, then back down) or ``"list"``.
    values : numpy.ndarray
        The voltage path in volts (read-only).
    start, stop, step : float or None
        The ramp in volts; ``None`` for a list.
    """

    kind: str
    values: np.ndarray
    start: float | None = None
    stop: float | None = None
    step: float | None = None

    @property
    def peak(self) -> float:
        """The highest voltage of the path, in volts."""
        return float(np.max(self.values))


@dataclass(frozen=True)
class Scene:
    """A validated experiment in SI units; build it with :func:`load_scene` or :func:`parse_scene`.

    Attributes
    ----------
    shear_modulus : float
        ``μ`` in Pa.
    relative_permittivity : float
        ``εr``; the permittivity is ``ε = εr ε0`` (:attr:`permittivity`, F/m).
    thickness, zone_radius : float
        ``H`` and ``A`` of the unstretched membrane, in m.
    prestretch : float
        Equibiaxial prestretch ``λpre ≥ 1`` (1: none).
    wrinkling : str
        ``"refuse"`` or ``"tension-field"`` (:attr:`coexist.model.MembraneModel.wrinkling`).
    material : str
        ``"neo-hookean"`` or ``"gent"``; ``jlim`` is ``None`` for neo-Hookean.
    breakdown_field : float or None
        Breakdown field in V/m; ``None``: no breakdown check.
    zone_count : int
        Number ``N`` of identical zones sharing one gas and one voltage.
    controlled_pressure : float or None
        Gauge pressure in Pa held directly (pressure control), when there is no chamber.
    chamber : Chamber or None
        ``None``: the pressure is controlled directly (at ``controlled_pressure``).
    voltage : VoltagePath or None
        ``None``: no voltage, the electrostatic terms are not built at all.
    name, description, source : str
        ``source`` is the file path or the built-in scene name.
    fitted : dict
        Free-form notes of fitted parameters, carried through unchanged.
    defaulted : tuple of str
        The fields the scene file left out and that took their documented default (``[membrane].prestretch``,
        ``[chamber].atmospheric_pressure``, ``[voltage].start``, ``[voltage].step``); ``coexist check``
        marks them.
    controlled_pressure_field : str
        The controlled pressure's key as written in the file (for messages), e.g. ``[zones].pressure_kPa``.
    electrode_pattern : str
        ``"full"`` (the electrode covers each zone), ``"inner-circle"`` or ``"ring"`` (``[electrodes] pattern``);
        :meth:`zone_pattern` gives the :class:`~coexist.patterned.ZonePattern`.
    inner_fraction, outer_fraction : float or None
        Radius fractions of the reference state: the electrode disc's radius (inner-circle) or the ring's
        inner edge, and the ring's outer edge; None where the pattern has no such edge.
    passive_layers : int
        Layers of the regions without electrode (``[layers] passive``); the electrode regions are one layer.
    region_layers : tuple of int or None
        Every region's layers from the pole out (``[layers] regions``, instead of ``passive``); None: the
        electrode regions one layer, the passive ones :attr:`passive_layers`.

    Examples
    --------
    >>> scene = load_scene("tricircle")
    >>> scene.zone_count, scene.material
    (3, 'gent')
    >>> round(scene.p_hat(20e2), 4)  # the closing pressure, 20 mbar, as p̂ = p A/(μH)
    1.9037
    """

    shear_modulus: float
    relative_permittivity: float
    thickness: float
    zone_radius: float
    material: str
    zone_count: int
    jlim: float | None = None
    prestretch: float = DEFAULTS["prestretch"]
    wrinkling: str = DEFAULTS["wrinkling"]
    breakdown_field: float | None = None
    controlled_pressure: float | None = None
    chamber: Chamber | None = None
    voltage: VoltagePath | None = None
    name: str = ""
    description: str = ""
    fitted: dict = field(default_factory=dict)
    source: str = "<string>"
    defaulted: tuple = ()
    controlled_pressure_field: str = field(default="[zones].pressure_mbar", repr=False, compare=False)
    electrode_pattern: str = "full"
    inner_fraction: float | None = None
    outer_fraction: float | None = None
    passive_layers: int = 1
    region_layers: tuple | None = None

    # --- scales (docs/physics.md, seed eqs. 3-4) ------------------------------------------------------
    @property
    def permittivity(self) -> float:
        """``ε = εr ε0`` in F/m."""
        return self.relative_permittivity * VACUUM_PERMITTIVITY

    @property
    def pressure_scale(self) -> float:
        """``μH/A`` in Pa: ``p̂ = p A/(μH)``."""
        return self.shear_modulus * self.thickness / self.zone_radius

    @property
    def volume_scale(self) -> float:
        """``A³`` in m³: ``V̂ = V/A³``."""
        return self.zone_radius**3

    @property
    def voltage_scale(self) -> float:
        """``H √(μ/ε)`` in V: ``Φ̂ = (Φ/H) √(ε/μ)``."""
        return self.thickness * math.sqrt(self.shear_modulus / self.permittivity)

    @property
    def charge_scale(self) -> float:
        """``A² √(εμ)`` in C: ``Q̂ = Q/(A² √(εμ))``."""
        return self.zone_radius**2 * math.sqrt(self.permittivity * self.shear_modulus)

    @property
    def energy_scale(self) -> float:
        """``μ H A²`` in J: ``Ψ̂ = Ψ/(μHA²)``; equal to pressure scale × volume scale."""
        return self.shear_modulus * self.thickness * self.zone_radius**2

    @property
    def field_scale(self) -> float:
        """``√(μ/ε)`` in V/m: a true field normalises as ``Ê = E √(ε/μ)``."""
        return math.sqrt(self.shear_modulus / self.permittivity)

    # --- physical <-> normalised -----------------------------------------------------------------
    def p_hat(self, p):
        """``p̂ = p A/(μH)`` of a gauge pressure ``p`` in Pa (scalar or array).

        Parameters
        ----------
        p : float or array_like
            Gauge pressure in Pa.

        Returns
        -------
        float or numpy.ndarray
            ``p̂`` (a float for a scalar, an array of the same shape otherwise).
        """
        return _scaled(p, 1 / self.pressure_scale, "p")

    def pressure(self, p_hat):
        """Gauge pressure in Pa of a normalised pressure, ``p = p̂ μH/A``.

        Parameters
        ----------
        p_hat : float or array_like
            Normalised gauge pressure ``p̂``.

        Returns
        -------
        float or numpy.ndarray
            ``p`` in Pa (a float for a scalar, an array of the same shape otherwise).
        """
        return _scaled(p_hat, self.pressure_scale, "p_hat")

    def v_hat(self, volume):
        """``V̂ = V/A³`` of a volume in m³.

        Parameters
        ----------
        volume : float or array_like
            Volume ``V`` in m³.

        Returns
        -------
        float or numpy.ndarray
            ``V̂`` (a float for a scalar, an array of the same shape otherwise).
        """
        return _scaled(volume, 1 / self.volume_scale, "volume")

    def volume(self, v_hat):
        """Volume in m³ of a normalised volume, ``V = V̂ A³``.

        Parameters
        ----------
        v_hat : float or array_like
            Normalised volume ``V̂``.

        Returns
        -------
        float or numpy.ndarray
            ``V`` in m³ (a float for a scalar, an array of the same shape otherwise).
        """
        return _scaled(v_hat, self.volume_scale, "v_hat")

    def phi_hat(self, volts):
        """``Φ̂ = (Φ/H) √(ε/μ)`` of a voltage in V.

        Parameters
        ----------
        volts : float or array_like
            Voltage ``Φ`` in V.

        Returns
        -------
        float or numpy.ndarray
            ``Φ̂`` (a float for a scalar, an array of the same shape otherwise).
        """
        return _scaled(volts, 1 / self.voltage_scale, "volts")

    def voltage_of(self, phi_hat):
        """Voltage in V of a normalised voltage, ``Φ = Φ̂ H √(μ/ε)``.

        Parameters
        ----------
        phi_hat : float or array_like
            Normalised voltage ``Φ̂``.

        Returns
        -------
        float or numpy.ndarray
            ``Φ`` in V (a float for a scalar, an array of the same shape otherwise).
        """
        return _scaled(phi_hat, self.voltage_scale, "phi_hat")

    @property
    def voltage_hat_path(self) -> np.ndarray | None:
        """``Φ̂`` of every voltage of the path, or ``None`` without a ``[voltage]`` section."""
        return None if self.voltage is None else self.phi_hat(self.voltage.values)

    @property
    def chamber_volume_hat(self) -> float | None:
        """``V̂c = Vc/A³``, or ``None`` without a chamber."""
        return None if self.chamber is None else self.v_hat(self.chamber.volume)

    @property
    def closing_pressure_hat(self) -> float | None:
        """Normalised gauge pressure when the valves close, or ``None`` without a chamber."""
        return None if self.chamber is None else self.p_hat(self.chamber.closing_pressure)

    @property
    def atmospheric_pressure_hat(self) -> float | None:
        """``P̂atm = Patm A/(μH)``, or ``None`` without a chamber."""
        return None if self.chamber is None else self.p_hat(self.chamber.atmospheric_pressure)

    def dimensionless_groups(self) -> dict:
        """The scales (units in the key names) and the scene's normalised parameters.

        Returns
        -------
        dict
            ``pressure_scale_Pa`` (``μH/A``), ``volume_scale_m3`` (``A³``), ``voltage_scale_V``
            (``H√(μ/ε)``), ``charge_scale_C`` (``A²√(εμ)``), ``energy_scale_J`` (``μHA²``),
            ``field_scale_V_per_m`` (``√(μ/ε)``), ``thickness_over_radius`` (``H/A``); with a chamber also
            ``chamber_volume_hat``, ``atmospheric_pressure_hat`` and ``closing_pressure_hat``; under pressure
            control ``controlled_pressure_hat``; with a voltage path ``voltage_hat_max`` (``Φ̂`` of its
            peak); with a breakdown field ``breakdown_field_hat`` (``Êb = Eb √(ε/μ)``).
        """
        groups: dict[str, float | None] = {
            "pressure_scale_Pa": self.pressure_scale,
            "volume_scale_m3": self.volume_scale,
            "voltage_scale_V": self.voltage_scale,
            "charge_scale_C": self.charge_scale,
            "energy_scale_J": self.energy_scale,
            "field_scale_V_per_m": self.field_scale,
            "thickness_over_radius": self.thickness / self.zone_radius,
        }
        if self.chamber is not None:
            groups["chamber_volume_hat"] = self.chamber_volume_hat
            groups["atmospheric_pressure_hat"] = self.atmospheric_pressure_hat
            groups["closing_pressure_hat"] = self.closing_pressure_hat
        if self.controlled_pressure is not None:
            groups["controlled_pressure_hat"] = self.p_hat(self.controlled_pressure)
        if self.voltage is not None:
            groups["voltage_hat_max"] = self.phi_hat(self.voltage.peak)
        if self.breakdown_field is not None:
            groups["breakdown_field_hat"] = self.breakdown_field / self.field_scale
        return groups

    def check_closing_pressure(self, p_hat_max: float, snap_through: bool = True) -> None:
        """Raise :class:`SceneError` if the zones cannot hold the closing pressure.

        Parameters
        ----------
        p_hat_max : float
            The largest normalised pressure one zone can hold at zero voltage (the snap-through
            pressure of the zone's ``p̂–V̂`` curve, e.g. 1.879 for neo-Hookean without prestretch).
        snap_through : bool, optional
            Whether ``p_hat_max`` is a pressure maximum (True) or, for a curve that rises to the end of the
            model's range, the pressure there (the message then says so).

        Raises
        ------
        SceneError
            If the scene has a chamber and its closing pressure, normalised, is not below ``p_hat_max``
            (names the closing-pressure field). Without a chamber nothing is checked.
        """
        if self.chamber is None:
            return
        p_hat = float(self.p_hat(self.chamber.closing_pressure))
        if not p_hat < p_hat_max:
            mbar = self.chamber.closing_pressure / 100
            what = (
                "snap-through pressure p̂max"
                if snap_through
                else "largest pressure they hold within the model's range (no snap-through: the pressure rises to the "
                "end of the range, as near Gent locking)"
            )
            given, bound = told_apart(mbar, self.pressure(p_hat_max) / 100)
            given_hat, bound_hat = told_apart(p_hat, p_hat_max)
            raise SceneError(
                f"the zones cannot hold {given} mbar (p̂ = {given_hat}): it is at or above the "
                f"{what} = {bound_hat} ({bound} mbar); close the valves at a lower pressure",
                self.chamber.closing_pressure_field,
            )

    # --- the electrode pattern --------------------------------------------------------------------
    @property
    def patterned(self) -> bool:
        """Whether a zone is patterned (an electrode that does not cover the whole zone)."""
        return self.electrode_pattern != "full"

    def zone_pattern(self):
        """The regions of one zone, from the pole out (imports :mod:`coexist.patterned`, hence CasADi).

        ``"full"``: one region, electrode, one layer; ``"inner-circle"``: an electrode disc ``0 ≤ R < fA``
        (one layer) in a passive annulus of :attr:`passive_layers` layers; ``"ring"``: an electrode annulus
        ``fi A < R < fo A`` (one layer), passive inside and outside (the outside only when ``fo < 1``).

        Returns
        -------
        ZonePattern
            :meth:`ZonePattern.full`, :meth:`ZonePattern.inner_circle` or :meth:`ZonePattern.ring`.
        """
        return zone_pattern(
            self.electrode_pattern, self.inner_fraction, self.outer_fraction, self.passive_layers, self.region_layers
        )

    def require_uniform(self, what: str) -> None:
        """Raise :class:`SceneError` naming ``[electrodes].pattern`` if the zones are patterned.

        For a computation that takes the one-layer membrane only (every command and :class:`Simulation` take
        patterned zones through their :class:`~coexist.patterned.PatternedModel`; a Simulation given another
        model refuses them).

        Parameters
        ----------
        what : str
            The computation, for the message (e.g. ``"the ramp"``).

        Raises
        ------
        SceneError
            If :attr:`patterned`.
        """
        if self.patterned:
            raise SceneError(
                f'patterned zones (pattern "{self.electrode_pattern}") are shot with their own model '
                f"(coexist.patterned.PatternedModel): {what} takes zones with a full electrode",
                "[electrodes].pattern",
            )

    # --- effects and model -----------------------------------------------------------------------
    def effects(self) -> list[str]:
        """Names of the effects this scene calls for; nothing else is simulated.

        The first entries name the same effects as :attr:`coexist.model.MembraneModel.effects`.

        Returns
        -------
        list of str
            ``elasticity:<material>``, then ``electrostatics:ideal-dielectric`` with a voltage,
            ``prestretch`` when ``λpre ≠ 1``, ``electrodes:<pattern>`` and ``layers:<n>`` for a patterned
            zone (``electrodes:inner-circle``, ``layers:2``; the passive layers only when not 1),
            ``gas:isothermal-ideal-gas`` with a chamber (else ``pressure-control``), and ``breakdown-check``
            when a breakdown field is given.
        """
        names = [f"elasticity:{self.material}"]
        if self.voltage is not None:
            names.append("electrostatics:ideal-dielectric")
        if self.patterned:
            names.append(f"electrodes:{self.electrode_pattern}")
        if self.passive_layers != 1:
            names.append(f"layers:{self.passive_layers}")
        if self.region_layers is not None and set(self.region_layers) != {1}:
            names.append(f"layers:{','.join(map(str, self.region_layers))}")
        if self.prestretch != 1.0:
            names.append("prestretch")
        if self.wrinkling == "tension-field":
            names.append("wrinkling:tension-field")
        from .effects import Breakdown, GasChamber, PressureReservoir

        names.append(f"gas:{GasChamber.name}" if self.chamber is not None else PressureReservoir.name)
        if self.breakdown_field is not None:
            names.append(Breakdown.name)
        return names

    def elasticity(self):
        """The scene's elasticity effect (:func:`coexist.effects.material_from_name`).

        Returns
        -------
        NeoHookean or Gent
            The :mod:`coexist.effects` elasticity of :attr:`material` (with :attr:`jlim` for Gent).
        """
        from .effects import material_from_name

        return material_from_name(self.material, self.jlim)

    def model(self):
        """The :class:`coexist.model.MembraneModel` with exactly the scene's effects (imports CasADi).

        Built once per material, voltage on/off and prestretch in a process (:func:`coexist.model.build_model`,
        cached): scenes that differ in geometry, chamber or voltage path share one model.

        Returns
        -------
        MembraneModel
            The normalised one-zone model; electrostatics only when the scene has a ``[voltage]``.
        """
        return _shared_model(self.material, self.jlim, self.voltage is not None, float(self.prestretch), self.wrinkling)

    def values(self) -> list[tuple[str, str, str]]:
        """Every physical value of the scene as ``(field, value with unit, source)``, source ``"file"`` or
        ``"default"`` (a documented default the scene file left out, :attr:`defaulted`).

        Returns
        -------
        list of tuple of str
            E.g. ``("[membrane].thickness", "0.5 mm", "file")``; absent optional fields are left out.
        """
        c, v = self.chamber, self.voltage
        rows = [
            ("[membrane].material", self.material),
            ("[membrane].jlim", None if self.jlim is None else f"{self.jlim:.12g}"),
            ("[membrane].shear_modulus", f"{self.shear_modulus / 1e3:.12g} kPa"),
            ("[membrane].relative_permittivity", f"{self.relative_permittivity:.12g}"),
            ("[membrane].thickness", f"{self.thickness * 1e3:.12g} mm"),
            ("[membrane].zone_radius", f"{self.zone_radius * 1e3:.12g} mm"),
            ("[membrane].prestretch", f"{self.prestretch:.12g}"),
            ("[membrane].wrinkling", self.wrinkling),
            (
                "[membrane].breakdown_field",
                None if self.breakdown_field is None else f"{self.breakdown_field / 1e6:.12g} MV/m",
            ),
            ("[zones].count", f"{self.zone_count}"),
            (
                "[zones].pressure",
                None if self.controlled_pressure is None else f"{self.controlled_pressure / 100:.12g} mbar",
            ),
            ("[chamber].volume", None if c is None else f"{c.volume * 1e6:.12g} ml"),
            ("[chamber].closing_pressure", None if c is None else f"{c.closing_pressure / 100:.12g} mbar"),
            ("[chamber].atmospheric_pressure", None if c is None else f"{c.atmospheric_pressure / 1e3:.12g} kPa"),
            ("[electrodes].pattern", self.electrode_pattern if self.patterned else None),
            ("[electrodes].inner_fraction", None if self.inner_fraction is None else f"{self.inner_fraction:.12g}"),
            ("[electrodes].outer_fraction", None if self.outer_fraction is None else f"{self.outer_fraction:.12g}"),
            ("[layers].passive", f"{self.passive_layers}" if self.patterned and self.region_layers is None else None),
            (
                "[layers].regions",
                None if self.region_layers is None else ", ".join(map(str, self.region_layers)),
            ),
        ]
        if v is not None and v.kind == "ramp":
            rows += [(f"[voltage].{k}", f"{getattr(v, k) / 1e3:.12g} kV") for k in ("start", "stop", "step")]
        elif v is not None:
            rows.append(("[voltage].values", f"{len(v.values)} values up to {v.peak / 1e3:.12g} kV"))
        return [(k, val, "default" if k in self.defaulted else "file") for k, val in rows if val is not None]

    def to_dict(self) -> dict:
        """JSON-ready description: SI values with units in the key names, effects, groups, notes.

        Returns
        -------
        dict
            Keys ``name``, ``description``, ``source``, ``membrane``, ``zones``, ``chamber`` and ``voltage``
            (``None`` when absent), ``electrodes`` (``pattern``, ``inner_fraction``, ``outer_fraction``; None
            where the pattern has no such edge), ``layers`` (``passive``, and ``regions`` when the scene gives every
            region's layers), ``effects`` (:meth:`effects`),
            ``dimensionless_groups`` (:meth:`dimensionless_groups`) and ``fitted`` (dates as ISO strings,
            non-finite floats as strings).
        """
        membrane = {
            "material": self.material,
            "shear_modulus_Pa": self.shear_modulus,
            "relative_permittivity": self.relative_permittivity,
            "permittivity_F_per_m": self.permittivity,
            "thickness_m": self.thickness,
            "zone_radius_m": self.zone_radius,
            "prestretch": self.prestretch,
            "wrinkling": self.wrinkling,
            "breakdown_field_V_per_m": self.breakdown_field,
        }
        if self.jlim is not None:
            membrane["jlim"] = self.jlim
        chamber = (
            None
            if self.chamber is None
            else {
                "volume_m3": self.chamber.volume,
                "closing_pressure_Pa": self.chamber.closing_pressure,
                "atmospheric_pressure_Pa": self.chamber.atmospheric_pressure,
            }
        )
        voltage = (
            None
            if self.voltage is None
            else {
                "kind": self.voltage.kind,
                "start_V": self.voltage.start,
                "stop_V": self.voltage.stop,
                "step_V": self.voltage.step,
                "values_V": [float(v) for v in self.voltage.values],
            }
        )
        return {
            "name": self.name,
            "description": self.description,
            "source": self.source,
            "membrane": membrane,
            "zones": {"count": self.zone_count, "controlled_pressure_Pa": self.controlled_pressure},
            "chamber": chamber,
            "voltage": voltage,
            "electrodes": {
                "pattern": self.electrode_pattern,
                "inner_fraction": self.inner_fraction,
                "outer_fraction": self.outer_fraction,
            },
            "layers": {"passive": self.passive_layers}
            | ({} if self.region_layers is None else {"regions": list(self.region_layers)}),
            "effects": self.effects(),
            "dimensionless_groups": self.dimensionless_groups(),
            "fitted": _json_safe(self.fitted),
            "defaulted": list(self.defaulted),
        }


def zone_pattern(
    electrode_pattern: str, inner_fraction=None, outer_fraction=None, passive_layers: int = 1, region_layers=None
):
    """The :class:`~coexist.patterned.ZonePattern` of a scene's pattern fields (imports :mod:`coexist.patterned`).

    Parameters
    ----------
    electrode_pattern : str
        ``"full"``, ``"inner-circle"`` or ``"ring"`` (:data:`coexist.scene_format.PATTERNS`).
    inner_fraction, outer_fraction : float or None
        The electrode disc's radius (inner-circle) or the ring's edges, over the zone radius.
    passive_layers : int
        Layers of the regions without electrode.
    region_layers : sequence of int, optional
        Every region's layers from the pole out, instead (:meth:`~coexist.patterned.ZonePattern.with_layers`).

    Returns
    -------
    ZonePattern
        :meth:`~coexist.patterned.ZonePattern.full`, :meth:`~coexist.patterned.ZonePattern.inner_circle` or
        :meth:`~coexist.patterned.ZonePattern.ring`.

    Raises
    ------
    SceneError
        For an unknown pattern, or fractions and layers the pattern does not accept.
    """
    from .patterned import ZonePattern

    if electrode_pattern in ("inner-circle", "ring", "full"):
        if electrode_pattern == "inner-circle":
            zone = ZonePattern.inner_circle(inner_fraction, passive_layers=passive_layers)
        elif electrode_pattern == "ring":
            zone = ZonePattern.ring(inner_fraction, outer_fraction, passive_layers=passive_layers)
        else:
            zone = ZonePattern.full()
        return zone if region_layers is None else zone.with_layers(region_layers)
    raise SceneError(
        f"unknown pattern {electrode_pattern!r}{did_you_mean(str(electrode_pattern), PATTERNS)}",
        "pattern",
    )


@functools.lru_cache(maxsize=32)
def _shared_model(material: str, jlim: float | None, voltage: bool, prestretch: float, wrinkling: str = "refuse"):
    from .model import build_model

    return build_model(material, jlim, voltage=voltage, prestretch=prestretch, wrinkling=wrinkling)


def _scaled(x, factor, name="value"):
    """``x`` (a number or an array of numbers; NaN passes) times ``factor``; anything else is a SceneError naming
    ``name`` (text was a bare ValueError: review, helper-62)."""
    kind = "U" if isinstance(x, (str, bytes)) else np.asarray(x).dtype.kind
    if kind not in "iuf":
        raise SceneError(f"must be a number or an array of numbers, got {x!r}", name)
    if np.ndim(x) == 0:
        return float(x) * factor
    return np.asarray(x, dtype=float) * factor


def _json_safe(value):
    """TOML values as JSON values: dates become ISO strings, non-finite floats strings."""
    if isinstance(value, dict):
        return {str(k): _json_safe(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_json_safe(v) for v in value]
    if isinstance(value, (datetime.date, datetime.time)):
        return value.isoformat()
    if isinstance(value, float) and not math.isfinite(value):
        return str(value)
    return value


# --- loading ---------------------------------------------------------------------------------------
def builtin_scenes() -> dict[str, str]:
    """Built-in scene names with a one-line description each.

    Returns
    -------
    dict of str to str
        Scene name (sorted) to the first line of its ``description`` (``""`` if it has none).
    """
    out = {}
    for name in _builtin_names():
        doc = tomllib.loads(builtin_scene_text(name))
        text = str(doc.get("description", "")).strip()
        out[name] = text.splitlines()[0] if text else ""
    return out


def builtin_scene_text(name: str) -> str:
    """The TOML text of a built-in scene.

    Parameters
    ----------
    name : str
        Built-in scene name (see :func:`builtin_scenes`).

    Returns
    -------
    str
        The scene file's text.

    Raises
    ------
    SceneError
        If there is no built-in scene of that name (the closest name is suggested).
    """
    names = _builtin_names()
    if name not in names:
        raise SceneError(
            f"unknown built-in scene {name!r}{did_you_mean(name, names)} (built-in scenes: "
            f"{', '.join(names)}; or give the path of a .toml file)"
        )
    return (_SCENES / f"{name}.toml").read_text(encoding="utf-8")


#: the largest scene file read (a scene of 1000 zones and 2 x 100 000 listed voltages is ~3 MB): a device such as
#: /dev/zero, or a huge file given by mistake, is refused instead of read until the memory runs out
MAX_SCENE_BYTES = 16 * 1024 * 1024


def _read_scene_bytes(path: Path) -> bytes:
    """The bytes of the scene file ``path``: a regular file of at most :data:`MAX_SCENE_BYTES` (a device, FIFO or
    socket is refused before it is read: /dev/zero was read until the process was killed for its memory)."""
    import os
    import stat

    st = os.stat(path)  # FileNotFoundError / OSError: the caller's messages
    if not stat.S_ISREG(st.st_mode):
        raise SceneError(f"{str(path)!r} is not a regular file (a device, pipe or socket), not a scene")
    with open(path, "rb") as f:
        data = f.read(MAX_SCENE_BYTES + 1)
    if len(data) > MAX_SCENE_BYTES:
        raise SceneError(f"scene file {str(path)!r} is larger than {MAX_SCENE_BYTES // (1024 * 1024)} MB: not a scene")
    return data


def load_scene(name_or_path: str | Path | None = None) -> Scene:
    """Load a built-in scene by name, or a scene file by path (``None``: the default, ``tricircle``).

    A string ending in ``.toml`` or holding a path separator is a path; otherwise a built-in name,
    falling back to a file of that name if one exists.

    Parameters
    ----------
    name_or_path : str or pathlib.Path or None
        Built-in scene name, or path of a UTF-8 TOML scene file; ``None``: :data:`DEFAULT_SCENE`.

    Returns
    -------
    Scene
        The validated scene; its ``source`` is the path or the built-in name.

    Raises
    ------
    SceneError
        If the name is not a built-in scene, the file is missing, unreadable or not UTF-8, or the scene is
        invalid (:func:`parse_scene`).

    Examples
    --------
    >>> scene = load_scene()  # the default: the paper's experiment
    >>> scene.name, round(scene.zone_radius * 1e3, 4)  # zone radius in mm
    ('tricircle', 21.4165)
    """
    if name_or_path is None:
        name_or_path = DEFAULT_SCENE
    if not isinstance(name_or_path, (str, Path)):
        raise SceneError(
            f"must be a built-in scene name or a path, got {type(name_or_path).__name__} {name_or_path!r}", "scene"
        )
    text = str(name_or_path)
    looks_like_path = isinstance(name_or_path, Path) or text.endswith(".toml") or "/" in text or "\\" in text
    path = Path(name_or_path)
    if path.is_dir():
        raise SceneError(f"{str(path)!r} is a folder, not a scene (a .toml file or a built-in scene's name)")
    if not looks_like_path and (text in _builtin_names() or not Path(text).is_file()):
        return parse_scene(builtin_scene_text(text), source=text)
    try:
        data = _read_scene_bytes(path)
    except FileNotFoundError:
        raise SceneError(f"scene file {str(path)!r} not found") from None
    except OSError as exc:
        raise SceneError(f"cannot read scene file {str(path)!r}: {exc.strerror or exc}") from None
    try:
        source = data.decode("utf-8-sig")  # (a byte-order mark, as Windows Notepad writes one, is dropped)
    except UnicodeDecodeError as exc:
        raise SceneError(f"scene file {str(path)!r} is not UTF-8 text (byte {exc.start})") from None
    return parse_scene(source, source=str(path))


def parse_scene(text: str, source: str = "<string>") -> Scene:
    """Parse and validate the TOML text of a scene; every problem is a :class:`SceneError`.

    Parameters
    ----------
    text : str
        TOML text of the scene (sections and keys: :mod:`coexist.scene_format`).
    source : str
        Where the text came from, used in messages and as ``Scene.source``; its stem is the scene's
        name when the text gives none.

    Returns
    -------
    Scene
        The validated scene in SI units (the voltage path read-only).

    Raises
    ------
    SceneError
        For invalid TOML, or the first invalid section, key or value (naming the field).
    """
    if not isinstance(text, str):
        raise SceneError(f"a scene is TOML text (a str), got {type(text).__name__}", "text")
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise SceneError(f"invalid TOML in {source}: {exc}") from None
    except RecursionError:
        raise SceneError(f"invalid TOML in {source}: nested too deeply") from None
    fields = read_document(doc, source)
    if fields["chamber"] is not None:
        fields["chamber"] = Chamber(**fields["chamber"])
    if fields["voltage"] is not None:
        values = np.array(fields["voltage"].pop("values"), dtype=float)
        values.setflags(write=False)
        fields["voltage"] = VoltagePath(values=values, **fields["voltage"])
    return Scene(**fields)


#: the built-in scenes: package data beside this module, read as files (importlib.resources would cost 5 ms of
#: start-up for the same result in an installed package; a zipped install, which only it could read, is not
#: supported: the compiled and cached code needs a writable file system anyway)
_SCENES = Path(__file__).resolve().parent / "scenes"


def _builtin_names() -> list[str]:
    return sorted(p.name[:-5] for p in _SCENES.iterdir() if p.name.endswith(".toml"))
