"""From a scene to its answers: the whole pipeline in physical units.

``scene → model (only the scene's effects) → ZoneFamily (curves at every voltage) → gas closed at
the closing pressure → equilibria → ramp`` and the fit of the one free parameter (the zone radius).

Everything in normalised form depends on the material alone (the scales ``μH/A``, ``A³``,
``H√(μ/ε)`` carry the geometry), so one :class:`~coexist.branches.ZoneFamily` serves a whole fit
and sensitivity study: changing ``A``, ``μ``, the chamber or the closing pressure only changes the
gas and the voltage scale.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np
from scipy.optimize import brentq

from .branches import ZoneFamily
from .errors import ModelRangeError, SceneError
from .ramp import RampResult, _continue, _initial_state, run_ramp
from .scene import Scene
from .zones import GasChamber, PressureReservoir, equilibria

#: the pole-stretch grid ends at this fraction of the Gent locking stretch
LOCKING_MARGIN = 0.95
#: upper end of the pole-stretch grid for materials that do not lock
NEO_HOOKEAN_STRETCH_MAX = 6.0


def pole_stretch_max(scene: Scene) -> float:
    """Upper end of the pole-stretch grid: short of Gent locking (equibiaxial ``2λ² + λ⁻⁴ − 3 = Jlim``)."""
    if scene.material == "gent":
        return LOCKING_MARGIN * math.sqrt((scene.jlim + 3) / 2)
    return NEO_HOOKEAN_STRETCH_MAX * scene.prestretch


def snap_through_pressure(scene: Scene) -> float:
    """The largest normalised pressure one zone of the scene holds at zero voltage (its ``p̂max``)."""
    from .curves import pressure_volume_curve
    from .effects import Gent, NeoHookean, NoElectrostatics
    from .model import MembraneModel

    model = MembraneModel(Gent(scene.jlim) if scene.material == "gent" else NeoHookean(), NoElectrostatics(),
                          scene.prestretch)
    grid = scene.prestretch * (1 + np.linspace(np.sqrt(2e-3), np.sqrt(pole_stretch_max(scene) / scene.prestretch - 1),
                                               80) ** 2)
    curve = pressure_volume_curve(model, 0.0, grid, scene.settings)
    maxima = [lp.p_hat for lp in curve.limit_points if lp.kind == "pressure_max"]
    return float(maxima[0]) if maxima else float(np.max(curve.states.p_hat))


@dataclass
class Prepared:
    """A scene made ready to solve: model, family of zone curves, and the voltage path."""

    scene: Scene
    model: object
    family: ZoneFamily
    phi_path: np.ndarray
    p_hat_max: float


def prepare(scene: Scene, phi_margin: float = 1.0, n_u: int = 128, n_s: int | None = None) -> Prepared:
    """Build the model with the scene's effects and shoot its family of curves once.

    ``phi_margin > 1`` extends the voltage range (used when the scene is perturbed, e.g. ``μ``).
    ``n_s`` voltage nodes (equally spaced in ``Φ̂²``); ``None``: 17 up to ``Φ̂ = 0.3`` and the same
    node spacing beyond (the accuracy study shows 17 lose nothing at the default scene's range).
    """
    model = scene.model()
    phi_path = scene.voltage_hat_path if scene.voltage is not None else np.zeros(1)
    phi_max = float(np.max(phi_path)) * phi_margin
    if n_s is None:
        n_s = max(17, int(np.ceil(16 * (phi_max / 0.3) ** 2)) + 1)
    family = ZoneFamily(model, phi_max, pole_stretch_max(scene), scene.settings, n_u=n_u, n_s=n_s)
    c0 = family.curve(0.0)
    ext = [u for u in c0.pressure_extrema() if c0.dp(u - 1e-9) > 0]
    p_max = float(c0.p(ext[0])) if ext else float(np.max(c0.p(c0.grid)))
    return Prepared(scene, model, family, np.asarray(phi_path, dtype=float), p_max)


def closed_gas(prep: Prepared, scene: Scene | None = None):
    """What holds the zones' pressure: the gas when the valves close (all zones on the rising branch
    at the closing pressure, 0 V) — or, in a scene without a chamber, a pressure reservoir at the
    scene's controlled pressure (``[zones].pressure_*``)."""
    scene = scene or prep.scene
    if scene.chamber is None:
        if scene.controlled_pressure is None:
            raise SceneError("this computation needs a [chamber] (a gas the zones share) or a controlled "
                             "pressure [zones].pressure_mbar", "[chamber]")
        p_hat = scene.p_hat(scene.controlled_pressure)
        if not p_hat < prep.p_hat_max:
            raise SceneError(f"the zones cannot hold {scene.controlled_pressure / 100:.4g} mbar (p̂ = {p_hat:.4g}): "
                             f"it is at or above their snap-through pressure p̂max = {prep.p_hat_max:.4g}",
                             "[zones].pressure")
        return PressureReservoir(float(p_hat))
    scene.check_closing_pressure(prep.p_hat_max)
    c0 = prep.family.curve(0.0)
    pc = scene.closing_pressure_hat
    first = c0.branches[0]
    if not first.p_range[0] <= pc <= first.p_range[1]:
        raise SceneError(f"closing pressure p̂ = {pc:.4g} is below the smallest computed state "
                         f"(p̂ = {first.p_range[0]:.3g}); raise it", scene.chamber.closing_pressure_field)
    uc = c0.stretch_at_pressure(first, pc)
    total = scene.zone_count * float(c0.v(uc))
    return GasChamber.closed_at(scene.chamber_volume_hat, scene.atmospheric_pressure_hat, pc, total)


@dataclass
class RampReport:
    """A ramp in physical units, ready for tables, JSON and figures."""

    scene: Scene
    result: RampResult
    gas: GasChamber
    family_error: dict
    effects: list
    fitted: dict = field(default_factory=dict)

    def voltage_kV(self, phi_hat):
        return self.scene.voltage_of(phi_hat) / 1e3

    def pressure_mbar(self, p_hat):
        return self.scene.pressure(p_hat) / 100

    def volume_ml(self, v_hat):
        return self.scene.volume(v_hat) * 1e6

    def to_dict(self) -> dict:
        steps = []
        for s in self.result.steps:
            st = s.state
            steps.append({
                "voltage_kV": round(float(self.voltage_kV(s.phi_hat)), 10),
                "direction": s.direction,
                "pressure_mbar": None if st is None else float(self.pressure_mbar(st.p_hat)),
                "zone_volumes_ml": None if st is None else [float(self.volume_ml(v)) for v in st.zone_volumes],
                "pole_stretches": None if st is None else (
                    [st.pole_stretch_unbulged] * (st.zones - st.k) + [st.pole_stretch_bulged] * st.k),
                "configuration": "none" if st is None else st.label,
                "bulged_zones": None if st is None else st.k,
                "stable": False if st is None else bool(st.stable),
                "polished": st is not None and "polished" in st.notes,
                **({"max_field_MV_per_m": s.max_field / 1e6} if s.max_field is not None else {}),
                **({"note": s.note} if s.note else {}),
            })
        trans = [{
            "voltage_kV": float(self.voltage_kV(t.phi_hat)),
            "voltage_kV_bracket": [float(self.voltage_kV(x)) for x in t.phi_hat_bracket],
            "from": t.from_label, "to": t.to_label, "kind": t.kind, "direction": t.direction,
        } for t in self.result.transitions + self.result.equal_free_energy]
        return {
            "scene": self.scene.to_dict(),
            "effects": self.effects,
            "fitted_parameters": self.fitted,
            "relative_tolerance": self.scene.settings.rtol,
            "curve_interpolation_error": self.family_error,
            "gas_amount_hat": getattr(self.gas, "gas_amount", None),
            "steps": steps,
            "transitions": trans,
            "notes": self.result.notes,
        }


def simulate_ramp(scene: Scene, progress=None, prep: Prepared | None = None) -> RampReport:
    """Run the scene's voltage ramp (or list of voltages) through the whole pipeline."""
    if scene.voltage is None:
        raise SceneError("this scene has no [voltage]: nothing to ramp", "[voltage]")
    prep = prep or prepare(scene)
    gas = closed_gas(prep, scene)
    result = run_ramp(prep.family, gas, scene.zone_count, scene.voltage_hat_path, progress=progress)
    _polish_path(prep, gas, result)
    if scene.breakdown_field is not None:  # the breakdown effect: only when the scene asks for it
        _check_breakdown(prep, scene, result)
    err = prep.family.interpolation_error()
    return RampReport(scene, result, gas, err, scene.effects(), dict(scene.fitted))


def _polish_path(prep: Prepared, gas, result: RampResult) -> None:
    """Replace every state on the path by its directly shot, Newton-polished version (in place)."""
    from .zones import polish

    def key(st):
        # the same configuration at the same voltage, reached going up and coming down, is one state
        return (round(st.phi_hat, 12), st.k, round(st.pole_stretch_unbulged, 7),
                None if st.pole_stretch_bulged is None else round(st.pole_stretch_bulged, 7))

    on_path = [s for s in result.steps if s.state is not None]
    unique = {}
    for s in on_path:
        unique.setdefault(key(s.state), s.state)
    polished = dict(zip(unique, polish(prep.model, gas, list(unique.values()), prep.scene.settings)))
    for s in on_path:
        s.state = polished[key(s.state)]


def _check_breakdown(prep: Prepared, scene: Scene, result: RampResult) -> None:
    """End the path where the largest true field in any zone exceeds the breakdown field (in place).

    The field ``E = Ê √(μ/ε)`` with ``Ê = Φ̂ λ1λ2`` largest over each zone (from shooting the path's
    states). Every step keeps its field in ``max_field`` (V/m); after breakdown the membrane is gone.
    """
    from .ramp import Transition
    from .shooting import solve_states

    on_path = [s for s in result.steps if s.state is not None]
    lam = [x for s in on_path for x in ([s.state.pole_stretch_unbulged]
                                         + ([s.state.pole_stretch_bulged] if s.state.k else []))]
    phi = [s.phi_hat for s in on_path for _ in range(2 if s.state.k else 1)]
    if not lam:
        return
    shot = solve_states(prep.model, lam, phi, scene.settings)
    fields = iter(np.where(shot.ok, shot.max_field, np.inf) * scene.field_scale)
    broken = None
    for step in result.steps:
        if broken is not None:
            step.state, step.note, step.equilibria = None, f"the membrane broke down at {broken:.4g} kV", []
            continue
        if step.state is None:
            continue
        step.max_field = max(next(fields) for _ in range(2 if step.state.k else 1))
        if step.max_field > scene.breakdown_field:
            broken = scene.voltage_of(step.phi_hat) / 1e3
            result.transitions.append(Transition(step.phi_hat, "breakdown", step.state.label, "broken down",
                                                 step.direction, (step.phi_hat, step.phi_hat)))
            note = (f"electric breakdown: the field reaches {step.max_field / 1e6:.4g} MV/m, above the "
                    f"breakdown field {scene.breakdown_field / 1e6:.4g} MV/m")
            result.notes.append(note)
            step.note, step.state, step.equilibria = note, None, []


def transition_voltage(prep: Prepared, scene: Scene, kind: str = "spinodal") -> float:
    """The first voltage (V) on the way up at which the zones stop being homogeneous.

    ``kind = "spinodal"``: where the homogeneous state loses stability (what a slow ramp shows);
    ``"equal_free_energy"``: where one bulged zone has the same total free energy as none.
    """
    gas = closed_gas(prep, scene)
    top = float(prep.family.phi_max)
    phis = np.linspace(0.0, top, 121)
    eqs0 = equilibria(prep.family.curve(0.0), gas, scene.zone_count)
    state = _initial_state(eqs0)
    if kind == "spinodal":
        prev = 0.0
        for phi in phis[1:]:
            nxt = _continue(state, equilibria(prep.family.curve(phi), gas, scene.zone_count))
            if nxt is None:
                lo, hi = prev, phi
                ref = state
                while hi - lo > 1e-11:
                    mid = 0.5 * (lo + hi)
                    n2 = _continue(ref, equilibria(prep.family.curve(mid), gas, scene.zone_count))
                    if n2 is None:
                        hi = mid
                    else:
                        lo, ref = mid, n2
                return scene.voltage_of(0.5 * (lo + hi))
            state, prev = nxt, phi
        raise ModelRangeError(f"the zones stay homogeneous up to {scene.voltage_of(top) / 1e3:.4g} kV",
                              "no_transition")
    if kind == "equal_free_energy":
        return equal_free_energy_voltage(prep, scene, 1, gas)
    raise SceneError(f"unknown transition kind {kind!r}; use 'spinodal' or 'equal_free_energy'", "kind")


def fit_zone_radius(scene: Scene, target_voltage: float, kind: str = "spinodal", prep: Prepared | None = None,
                    bracket_mm=None) -> float:
    """The zone radius ``A`` (m) that puts the first transition of the ramp at ``target_voltage`` (V).

    The radius enters only through the gas and the pressure scale, so one family of curves serves
    every trial radius; the root is found by Brent's method to 1e-7 mm. The admissible radii are
    those whose closing pressure the zones can hold (``p̂close < p̂max``).
    """
    prep = prep or prepare(scene, phi_margin=1.0)
    mu_h = scene.shear_modulus * scene.thickness
    a_max = prep.p_hat_max * mu_h / scene.chamber.closing_pressure  # closing pressure = snap-through
    lo_mm, hi_mm = bracket_mm or (0.5 * a_max * 1e3, a_max * 1e3 * (1 - 1e-6))

    def f(a_mm):
        trial = replace(scene, zone_radius=a_mm / 1e3)
        try:
            return transition_voltage(prep, trial, kind) - target_voltage
        except ModelRangeError:
            return float(scene.voltage_of(prep.family.phi_max)) - target_voltage + 1.0

    a_mm = np.linspace(lo_mm, hi_mm, 12)
    vals = [f(a) for a in a_mm]
    for i in range(len(a_mm) - 1):
        if vals[i] * vals[i + 1] < 0:
            return brentq(f, a_mm[i], a_mm[i + 1], xtol=1e-7) / 1e3
    raise ModelRangeError(f"no zone radius in {lo_mm:.4g}..{hi_mm:.4g} mm puts the transition at "
                          f"{target_voltage / 1e3:.4g} kV", "no_fit")


def _delta_g(prep, scene, gas, k, phi):
    """``G(k bulged, stable) − G(homogeneous)`` at ``Φ̂``, or None where either does not exist."""
    eqs = equilibria(prep.family.curve(phi), gas, scene.zone_count)
    hom = [e for e in eqs if e.k == 0 and e.branch_unbulged == 0]
    mix = [e for e in eqs if e.k == k and e.stable]
    if not hom or not mix:
        return None
    return min(m.free_energy for m in mix) - min(hom, key=lambda e: e.v_unbulged).free_energy


def equal_free_energy_voltage(prep: Prepared, scene: Scene, k: int = 1, gas=None, samples: int = 121) -> float:
    """The lowest voltage (V) at which ``k`` bulged zones have the free energy of the homogeneous state.

    Scans ``Φ̂`` over the family's range, then bisects (to 1e-11 in ``Φ̂``) the first interval where
    the difference turns negative; if the bulged configuration only appears inside that interval
    and is already lower there, its appearance voltage is returned.
    """
    gas = gas or closed_gas(prep, scene)
    phis = np.linspace(0.0, float(prep.family.phi_max), samples)

    def delta(phi):
        return _delta_g(prep, scene, gas, k, phi)

    vals = [delta(p) for p in phis]
    for i in range(1, phis.size):
        a, b = vals[i - 1], vals[i]
        if b is None or b > 0:
            continue
        lo, hi = phis[i - 1], phis[i]
        if a is None:
            while hi - lo > 1e-11:
                mid = 0.5 * (lo + hi)
                lo, hi = (lo, mid) if delta(mid) is not None else (mid, hi)
            lo = hi
            if delta(lo) <= 0:
                return scene.voltage_of(lo)
            hi = phis[i]
        elif a <= 0:
            continue
        while hi - lo > 1e-11:
            mid = 0.5 * (lo + hi)
            d = delta(mid)
            if d is None:
                break
            lo, hi = (mid, hi) if d > 0 else (lo, mid)
        return scene.voltage_of(0.5 * (lo + hi))
    raise ModelRangeError(f"no voltage up to {scene.voltage_of(phis[-1]) / 1e3:.4g} kV at which {k} bulged "
                          f"zone{'s' if k > 1 else ''} reach the free energy of the homogeneous state",
                          "no_transition")


@dataclass
class CoexistenceEntry:
    """What is known of the configuration with ``k`` of ``N`` zones bulged."""

    k: int
    stable_range_kV: list
    equal_free_energy_kV: float | None
    state: object | None
    note: str | None = None


def coexistence_table(prep: Prepared, scene: Scene, samples: int = 121) -> list[CoexistenceEntry]:
    """For each ``k = 1..N−1``: the voltages where ``k`` bulged zones are stable, their equal-free-energy
    voltage against the homogeneous state, and the coexisting states there."""
    gas = closed_gas(prep, scene)
    phis = np.linspace(0.0, float(prep.family.phi_max), samples)
    eqs = [equilibria(prep.family.curve(p), gas, scene.zone_count) for p in phis]
    out = []
    for k in range(1, scene.zone_count):
        present = np.array([any(e.k == k and e.stable for e in es) for es in eqs])
        ranges = []
        i = 0
        while i < phis.size:
            if present[i]:
                j = i
                while j + 1 < phis.size and present[j + 1]:
                    j += 1
                ranges.append([float(scene.voltage_of(phis[i]) / 1e3), float(scene.voltage_of(phis[j]) / 1e3)])
                i = j + 1
            else:
                i += 1
        try:
            v = equal_free_energy_voltage(prep, scene, k, gas, samples)
            phi = scene.phi_hat(v)
            cands = [e for e in equilibria(prep.family.curve(phi), gas, scene.zone_count) if e.k == k and e.stable]
            state = min(cands, key=lambda e: e.free_energy) if cands else None
            if state is not None:
                from .zones import polish

                state = polish(prep.model, gas, [state], scene.settings)[0]
            out.append(CoexistenceEntry(k, ranges, v / 1e3, state))
        except ModelRangeError as exc:
            out.append(CoexistenceEntry(k, ranges, None, None, str(exc)))
    return out


def sensitivity(scene: Scene, prep: Prepared | None = None, relative_change: float = 0.01) -> list[dict]:
    """How the transition voltages move when each input moves by ``±relative_change``.

    Inputs: zone radius (the fitted one), shear modulus, closing pressure, chamber volume. One
    family of curves serves them all (the normalised curves depend on the material only).
    """
    prep = prep or prepare(scene, phi_margin=1.15)
    rows = []

    def both(sc):
        out = {}
        for kind in ("spinodal", "equal_free_energy"):
            try:
                out[kind] = transition_voltage(prep, sc, kind) / 1e3
            except (ModelRangeError, SceneError) as exc:
                out[kind] = None
                out[f"{kind}_note"] = str(exc)
        return out

    base = both(scene)
    rows.append({"parameter": "baseline", "value": None, **base})
    ch = scene.chamber
    perturb = {
        "zone_radius_mm": (scene.zone_radius * 1e3, lambda x: replace(scene, zone_radius=x / 1e3)),
        "shear_modulus_kPa": (scene.shear_modulus / 1e3, lambda x: replace(scene, shear_modulus=x * 1e3)),
        "closing_pressure_mbar": (ch.closing_pressure / 100,
                                  lambda x: replace(scene, chamber=replace(ch, closing_pressure=x * 100))),
        "chamber_volume_ml": (ch.volume * 1e6, lambda x: replace(scene, chamber=replace(ch, volume=x / 1e6))),
    }
    for name, (value, make) in perturb.items():
        for sign in (-1, 1):
            x = value * (1 + sign * relative_change)
            rows.append({"parameter": name, "value": x, **both(make(x))})
    return rows
