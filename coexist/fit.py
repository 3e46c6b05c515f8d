"""Fitting the one free parameter (the zone radius) to an observed transition, and the sensitivity table.

The radius enters only through the gas and the scales (the normalised zone curves depend on the
material alone), so one model serves every trial radius; each trial builds its own gas and traces
its own exact equilibria (:class:`~coexist.simulation.Simulation`).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from . import validation
from .errors import CoexistError, ModelRangeError, SceneError
from .numerics.roots import bracketed_root
from .scene import Scene
from .settings import SolverSettings
from .simulation import Simulation, pole_stretch_max, snap_through, zone_model


@dataclass
class Shared:
    """What every trial of a fit shares: the model, the zone's snap-through at zero voltage, and the
    solver settings."""

    model: object
    snap: tuple
    settings: SolverSettings

    @classmethod
    def of(cls, scene: Scene, settings: SolverSettings | None = None) -> Shared:
        """Build the model of ``scene`` and solve its snap-through once.

        Parameters
        ----------
        scene : Scene
            The scene whose material, prestretch and electrostatics give the model (its radius is not used).
        settings : SolverSettings, optional
            Solver settings of every trial (default :class:`~coexist.settings.SolverSettings`).

        Returns
        -------
        Shared
            The model, ``snap = (p̂max, λ0 at it)`` of one zone at zero voltage
            (:func:`~coexist.simulation.snap_through`), and the settings.
        """
        settings = validation.settings_or_default(settings)
        validation.scene(scene)
        model = zone_model(scene)  # a patterned scene's zones: their PatternedModel
        return cls(model, snap_through(model, settings, pole_stretch_max(scene, settings)), settings)


#: the transitions a zone radius can be fitted to
TRANSITION_KINDS = ("spinodal", "equal_free_energy")


def transition_voltage(
    scene: Scene, kind: str = "spinodal", shared: Shared | None = None, measure: bool = False
) -> tuple[float, float]:
    """The first transition on the way up from the closing state, in volts, and its error.

    ``kind = "spinodal"``: where the homogeneous state is lost (what a slow ramp shows);
    ``"equal_free_energy"``: where one bulged zone first has the total free energy of none.
    ``measure``: measure the error by re-locating at ``rtol/100`` (else the location bracket).

    Parameters
    ----------
    scene : Scene
        The scene, with its chamber (or controlled pressure) and voltage path.
    kind : {"spinodal", "equal_free_energy"}, optional
        Which transition (default ``"spinodal"``).
    shared : Shared, optional
        Model and snap-through shared between trials (default: built from ``scene``).
    measure : bool, optional
        True: keep ``shared.settings`` (the error is measured if its ``error_estimates`` is on); False
        (default): the error is the location bracket only.

    Returns
    -------
    voltage : float
        The transition voltage ``Φ = Φ̂ H √(μ/ε)`` in V.
    error : float
        Its estimated error in V.

    Raises
    ------
    SceneError
        If ``kind`` is unknown, or the zones cannot hold the closing pressure
        (:meth:`~coexist.simulation.Simulation.from_scene`).
    ModelRangeError
        If there is no such transition in the scene's voltage window (``reason="no_transition"``).
    """
    if kind not in TRANSITION_KINDS:
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

    With ``A_max = p̂max μH / p_close`` the radius at which the closing pressure is the snap-through, the
    trial radii crowd geometrically towards ``A_max``; without a bracket, up to three rounds resample
    around the radii where the transition starts to exist.

    Parameters
    ----------
    scene : Scene
        The scene (with ``[chamber]`` and ``[voltage]``); its own ``zone_radius`` is replaced by each trial.
    target_voltage : float
        The observed transition voltage, in V.
    kind : {"spinodal", "equal_free_energy"}, optional
        Which transition to fit (default ``"spinodal"``), as :func:`transition_voltage`.
    shared : Shared, optional
        Model and snap-through shared between trials (default: built from ``scene``).
    bracket_mm : (float, float), optional
        Smallest and largest trial radius in mm (default ``(0.5 A_max, (1 − 1e-6) A_max)``).

    Returns
    -------
    float
        The fitted zone radius ``A`` in m.

    Raises
    ------
    SceneError
        If the scene has no ``[chamber]`` or no ``[voltage]``, or ``kind`` is unknown.
    ModelRangeError
        If no radius in the bracket puts the transition at ``target_voltage`` (``reason="no_fit"``; the
        message gives the range of transitions the radii reach).
    """
    validation.scene(scene)
    if scene.chamber is None or scene.voltage is None:
        raise SceneError("fitting needs a scene with [chamber] and [voltage]", "[chamber]")
    target_voltage = validation.real(target_voltage, "target_voltage", lo=0.0, lo_open=True)
    if kind not in TRANSITION_KINDS:
        raise SceneError(f"unknown transition kind {kind!r}; use 'spinodal' or 'equal_free_energy'", "kind")
    shared = shared or Shared.of(scene)
    mu_h = scene.shear_modulus * scene.thickness
    a_max = shared.snap[0] * mu_h / scene.chamber.closing_pressure  # closing pressure = snap-through
    lo_mm, hi_mm = bracket_mm or (0.5 * a_max * 1e3, a_max * 1e3 * (1 - 1e-6))
    if not (0 < lo_mm < hi_mm < a_max * 1e3):
        raise SceneError(
            f"the radius bracket must satisfy 0 < low < high < {a_max * 1e3:.6g} mm (the largest radius whose "
            f"zones hold the closing pressure), got {lo_mm!r}..{hi_mm!r} mm",
            "bracket_mm",
        )

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

    Parameters
    ----------
    scene : Scene
        The baseline scene, with a ``[chamber]``.
    relative_change : float, optional
        Relative change of each input (default 0.01).
    shared : Shared, optional
        Model and snap-through shared between trials (default: built from ``scene``).

    Returns
    -------
    list of dict
        The baseline row (``parameter="baseline"``, ``value=None``), then for each of ``zone_radius_mm``,
        ``shear_modulus_kPa``, ``closing_pressure_mbar``, ``chamber_volume_ml`` a row at ``value·(1 −
        relative_change)`` and one at ``value·(1 + relative_change)``. Each row has the ``spinodal`` and
        ``equal_free_energy`` voltages in kV, None (with a ``{kind}_note``) where a transition failed.

    Raises
    ------
    SceneError
        If the scene has no ``[chamber]``.
    """
    validation.scene(scene)
    if scene.chamber is None:
        raise SceneError("the sensitivity table needs a scene with a [chamber]", "[chamber]")
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
