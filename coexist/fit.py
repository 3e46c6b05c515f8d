"""Fitting the one free parameter (the zone radius) to an observed transition, and the sensitivity table.

The radius enters only through the gas and the scales (the normalised zone curves depend on the
material alone), so one model serves every trial radius; each trial builds its own gas and traces
its own exact equilibria (:class:`~coexist.simulation.Simulation`).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from .errors import CoexistError, ModelRangeError, SceneError
from .numerics.roots import bracketed_root
from .scene import Scene
from .settings import SolverSettings
from .simulation import Simulation, pole_stretch_max, snap_through


@dataclass
class Shared:
    """What every trial of a fit shares: the model, the zone's snap-through at zero voltage, and the
    solver settings."""

    model: object
    snap: tuple
    settings: SolverSettings

    @classmethod
    def of(cls, scene: Scene, settings: SolverSettings | None = None) -> Shared:
        """Build the model of ``scene`` and solve its snap-through once."""
        settings = settings or SolverSettings()
        model = scene.model()
        return cls(model, snap_through(model, settings, pole_stretch_max(scene, settings)), settings)


def transition_voltage(
    scene: Scene, kind: str = "spinodal", shared: Shared | None = None, measure: bool = False
) -> tuple[float, float]:
    """The first transition on the way up from the closing state, in volts, and its error.

    ``kind = "spinodal"``: where the homogeneous state is lost (what a slow ramp shows);
    ``"equal_free_energy"``: where one bulged zone first has the total free energy of none.
    ``measure``: measure the error by re-locating at ``rtol/100`` (else the location bracket).
    """
    if kind not in ("spinodal", "equal_free_energy"):
        raise SceneError(f"unknown transition kind {kind!r}; use 'spinodal' or 'equal_free_energy'", "kind")
    shared = shared or Shared.of(scene)
    settings = shared.settings if measure else replace(shared.settings, error_estimates=False)
    sim = Simulation.from_scene(scene, settings, model=shared.model, snap=shared.snap)
    t = sim.first_transition(kind)
    return float(scene.voltage_of(t.phi_hat)), float(scene.voltage_of(t.phi_hat_error))


def fit_zone_radius(
    scene: Scene, target_voltage: float, kind: str = "spinodal", shared: Shared | None = None, bracket_mm=None
) -> float:
    """The zone radius ``A`` (m) that puts the first transition of the ramp at ``target_voltage`` (V).

    The admissible radii are those whose closing pressure the zones can hold (``p̂close < p̂max``). The
    transition is evaluated at ``settings.fit_samples`` radii; a radius at which it does not exist (no
    stable start, or no transition below the scene's top voltage) is left out, never scored. The Illinois
    method (:func:`~coexist.numerics.roots.bracketed_root`) then solves between the first two
    neighbouring radii whose transitions lie on either side of the target (to 1e-9 mm).
    """
    if scene.chamber is None or scene.voltage is None:
        raise SceneError("fitting needs a scene with [chamber] and [voltage]", "[chamber]")
    shared = shared or Shared.of(scene)
    mu_h = scene.shear_modulus * scene.thickness
    a_max = shared.snap[0] * mu_h / scene.chamber.closing_pressure  # closing pressure = snap-through
    lo_mm, hi_mm = bracket_mm or (0.5 * a_max * 1e3, a_max * 1e3 * (1 - 1e-6))

    def f(a_mm):
        trial = replace(scene, zone_radius=a_mm / 1e3)
        return transition_voltage(trial, kind, shared)[0] - target_voltage

    # the transitions move fastest as the closing pressure nears the snap-through (a → a_max): the
    # trial radii crowd there, geometrically in the distance from it
    top = a_max * 1e3
    gaps = np.geomspace(top - lo_mm, max(top - hi_mm, 1e-12), shared.settings.fit_samples)
    radii = top - gaps
    tried = {}
    why = []

    def value(a):
        if a not in tried:
            try:
                tried[a] = f(a)
            except CoexistError as exc:
                tried[a] = None
                why.append(f"{a:.4g} mm: {exc}")
        return tried[a]

    for a in radii:
        value(a)
    for _ in range(3):
        valid = sorted((a, v) for a, v in tried.items() if v is not None)
        for (a0, v0), (a1, v1) in zip(valid[:-1], valid[1:]):
            if v0 == 0:
                return a0 / 1e3
            if v0 * v1 < 0:
                root = bracketed_root(lambda a, _: np.array([f(float(a[0]))]), a0, a1, v0, v1, xtol=1e-9)
                return float(root.x[0]) / 1e3
        # no bracket yet: where the transition starts to exist (a radius without one next to a radius
        # with one), the transitions run furthest; sample there, closer each round
        order = sorted(tried)
        edges = [(a, b) for a, b in zip(order[:-1], order[1:]) if (tried[a] is None) != (tried[b] is None)]
        if not edges:
            break
        for a, b in edges:
            for frac in (0.25, 0.5, 0.75):
                value(a + frac * (b - a))
    valid = sorted((a, v) for a, v in tried.items() if v is not None)
    reach = (
        (
            f"transitions between {min(v for _, v in valid) / 1e3 + target_voltage / 1e3:.4g} and "
            f"{max(v for _, v in valid) / 1e3 + target_voltage / 1e3:.4g} kV"
        )
        if valid
        else "no transition at all"
    )
    raise ModelRangeError(
        f"no zone radius in {lo_mm:.4g}..{hi_mm:.4g} mm puts the {kind} transition at "
        f"{target_voltage / 1e3:.4g} kV: the radii give {reach}" + (f"; without one: {why[0]}" if why else ""),
        "no_fit",
    )


def sensitivity(scene: Scene, relative_change: float = 0.01, shared: Shared | None = None) -> list[dict]:
    """How the transition voltages move when each input moves by ``±relative_change``.

    Inputs: zone radius (the fitted one), shear modulus, closing pressure, chamber volume. The shear
    modulus changes the voltage scale and the gas, not the normalised model, so one model serves all.
    """
    shared = shared or Shared.of(scene)
    rows: list[dict] = []

    def both(sc):
        out: dict[str, float | str | None] = {}
        for kind in ("spinodal", "equal_free_energy"):
            try:
                out[kind] = transition_voltage(sc, kind, shared)[0] / 1e3
            except CoexistError as exc:
                out[kind] = None
                out[f"{kind}_note"] = str(exc)
        return out

    rows.append({"parameter": "baseline", "value": None, **both(scene)})
    ch = scene.chamber
    if ch is None:
        raise SceneError("the sensitivity table needs a scene with a [chamber]", "[chamber]")
    perturb = {
        "zone_radius_mm": (scene.zone_radius * 1e3, lambda x: replace(scene, zone_radius=x / 1e3)),
        "shear_modulus_kPa": (scene.shear_modulus / 1e3, lambda x: replace(scene, shear_modulus=x * 1e3)),
        "closing_pressure_mbar": (
            ch.closing_pressure / 100,
            lambda x: replace(scene, chamber=replace(ch, closing_pressure=x * 100)),
        ),
        "chamber_volume_ml": (ch.volume * 1e6, lambda x: replace(scene, chamber=replace(ch, volume=x / 1e6))),
    }
    for name, (value, make) in perturb.items():
        for sign in (-1, 1):
            x = value * (1 + sign * relative_change)
            rows.append({"parameter": name, "value": x, **both(make(x))})
    return rows
