"""Fitting the one free parameter (the zone radius) to an observed transition, and the sensitivity table.

The radius enters only through the gas and the scales (the normalised zone curves depend on the
material alone), so one model serves every trial radius; each trial builds its own gas and traces
its own exact equilibria (:class:`~coexist.simulation.Simulation`).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from . import validation
from .errors import CoexistError, ModelRangeError, SceneError, SolverError
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

#: first step of the trial radii away from the scene's own radius, in ``ln A``; it doubles every step
FIRST_STEP = 0.01
#: without any radius that has a transition, gaps between trial radii are halved down to this, in ``ln A``
FILL_GAP = 0.04


def voltage_top_field(scene: Scene) -> str:
    """The scene field that sets the highest voltage of its path: ``[voltage].stop_kV`` for a ramp,
    ``[voltage].values_kV`` for a list.

    Parameters
    ----------
    scene : Scene
        A scene with a ``[voltage]`` section.

    Returns
    -------
    str
    """
    return "[voltage].stop_kV" if scene.voltage is not None and scene.voltage.kind == "ramp" else "[voltage].values_kV"


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
        If there is no such transition in the scene's voltage window (``reason="no_transition"``), also when
        the continuation locates one beyond the highest voltage of the scene's path ``Φtop``: a ramp of the
        scene never reaches it.
    """
    if kind not in TRANSITION_KINDS:
        raise SceneError(f"unknown transition kind {kind!r}; use 'spinodal' or 'equal_free_energy'", "kind")
    if shared is not None and not isinstance(shared, Shared):
        raise SceneError(f"shared must be a Shared (Shared.of(scene)), got {type(shared).__name__}", "shared")
    shared = shared or Shared.of(scene)
    settings = shared.settings if measure else replace(shared.settings, error_estimates=False)
    sim = Simulation.from_scene(scene, settings, model=shared.model, snap=shared.snap)
    t = sim.first_transition(kind)
    volts = float(scene.voltage_of(t.phi_hat))
    if scene.voltage is not None and volts > scene.voltage.peak:
        raise ModelRangeError(
            f"the first {kind} transition lies at {volts / 1e3:.6g} kV, above the scene's highest voltage "
            f"{scene.voltage.peak / 1e3:.6g} kV: a ramp of the scene does not reach it",
            "no_transition",
            above_top=True,
        )
    return volts, float(scene.voltage_of(t.phi_hat_error))


#: the relative step of the zone radius over which the slope ``dVt/dA`` of the fitted transition is taken for the
#: fitted radius's error (:func:`fitted_radius_error`)
SLOPE_STEP = 1e-7


def fitted_radius_error(
    fitted: Scene, kind: str, shared: Shared, transition: float, error: float, target: float
) -> float | None:
    """The error of a fitted zone radius: what the transition's error and its distance to the target move it by,

    ``δA = (δVt + |Vt − Vtarget|) / |dVt/dA|``,

    the slope a forward difference over :data:`SLOPE_STEP` of the radius (the transition moves ~1e3 times its own
    error over that step in the default scene: 3.6e-6 kV against 5e-9).

    Parameters
    ----------
    fitted : Scene
        The scene with the fitted zone radius.
    kind : {"spinodal", "equal_free_energy"}
        The transition fitted (:func:`transition_voltage`).
    shared : Shared
        Model and snap-through shared between trials.
    transition, error : float
        The fitted scene's transition and its error, in V.
    target : float
        The target voltage, in V.

    Returns
    -------
    float or None
        ``δA`` in m; None where the neighbouring radius has no transition, or the slope is zero.
    """
    a = fitted.zone_radius
    step = SLOPE_STEP * a
    try:
        beside = transition_voltage(replace(fitted, zone_radius=a + step), kind, shared)[0]
    except CoexistError:
        return None
    slope = (beside - transition) / step
    if not (np.isfinite(slope) and slope != 0):
        return None
    return float((error + abs(transition - target)) / abs(slope))


def fit_zone_radius(
    scene: Scene,
    target_voltage: float,
    kind: str = "spinodal",
    shared: Shared | None = None,
    bracket_mm=None,
    progress=None,
) -> float:
    """The zone radius ``A`` (m) that puts the first transition of the ramp at ``target_voltage`` (V).

    The admissible radii are those whose closing pressure the zones can hold, ``p̂close = p_close A/(μH) <
    p̂max``, i.e. ``A < A_max = p̂max μH / p_close`` (``p̂max`` the snap-through pressure at zero voltage, or
    for a curve without one, e.g. a stiff Gent material, the pressure at the end of the model's range). A
    radius at which the transition does not exist (no stable start, or no transition up to the scene's
    highest voltage ``Φtop``) is left out, never scored. The Illinois method
    (:func:`~coexist.numerics.roots.bracketed_root`) solves ``Φt(A) − Φtarget = 0`` between two
    neighbouring trial radii whose transitions lie on either side of the target, until
    ``|Φt(A) − Φtarget| ≤ rtol·Φtarget`` or the bracket is as narrow as the radius's floating-point resolution
    (the transition's own noise is about ``10 rtol Φt``).

    The trial radii start at the scene's own radius ``A0`` (clipped into the bracket) and widen
    geometrically in both directions, ``A_k+1 = A_k e^{±0.01·2^k}`` (steps of 1 %, 2 %, 4 % ...), upwards
    never more than 3/4 of the remaining way to ``A_max`` (they crowd there, where the transition moves
    fastest), until a pair brackets the target. A direction stops at the end of the bracket, or where
    the transition stops existing after it existed (the radii that give a transition may form a narrow
    band: a material without a snap-through at zero voltage transitions only in a band a few per cent
    wide). Without a bracket then, up to three rounds resample between neighbouring radii with and without
    a transition (where the transitions run furthest); if no radius had a transition, the widest gaps
    are halved (geometrically) down to 4 %. At most ``6·settings.fit_samples`` radii are tried.

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
        Smallest and largest trial radius in mm (default ``(min(0.5 A_max, A0)/8, (1 − 1e-6) A_max)``).
    progress : callable, optional
        Called after each radius is solved with ``(radius_mm, transition_V)`` (``None`` where the radius has no
        transition): a fit solves tens of them, a few seconds each on a slow scene.

    Returns
    -------
    float
        The fitted zone radius ``A`` in m.

    Raises
    ------
    SceneError
        If the scene has no ``[chamber]`` or no ``[voltage]``, ``kind`` is unknown, ``target_voltage`` is
        above the highest voltage of the scene's path (no ramp of the scene reaches it), or the bracket is
        not inside ``(0, A_max)``.
    ModelRangeError
        If no trial radius puts the transition at ``target_voltage`` (``reason="no_fit"``; the message gives
        the radii tried and the range of transitions they reach, all at most ``Φtop``).
    SolverError
        If the root between two bracketing radii does not converge.
    """
    validation.scene(scene)
    if scene.chamber is None or scene.voltage is None:
        raise SceneError("fitting needs a scene with [chamber] and [voltage]", "[chamber]")
    target_voltage = validation.real(target_voltage, "target_voltage", lo=0.0, lo_open=True)
    if kind not in TRANSITION_KINDS:
        raise SceneError(f"unknown transition kind {kind!r}; use 'spinodal' or 'equal_free_energy'", "kind")
    top_volts = scene.voltage.peak
    if target_voltage >= top_volts:  # a transition at the top itself is where the ramp turns: not located
        raise SceneError(
            f"the target {target_voltage / 1e3:.6g} kV is not below the highest voltage of the scene's path, "
            f"{top_volts / 1e3:.6g} kV ({voltage_top_field(scene)}): no ramp of the scene reaches past it",
            "target_voltage",
        )
    if shared is not None and not isinstance(shared, Shared):
        raise SceneError(f"shared must be a Shared (Shared.of(scene)), got {type(shared).__name__}", "shared")
    if bracket_mm is not None:
        if isinstance(bracket_mm, (str, bytes)) or not hasattr(bracket_mm, "__len__") or len(bracket_mm) != 2:
            raise SceneError(f"bracket_mm must be two radii (low, high) in mm, got {bracket_mm!r}", "bracket_mm")
        bracket_mm = tuple(validation.real(x, "bracket_mm") for x in bracket_mm)
    shared = shared or Shared.of(scene)
    mu_h = scene.shear_modulus * scene.thickness
    a_max = shared.snap[0] * mu_h / scene.chamber.closing_pressure  # closing pressure = p̂max
    a_own = scene.zone_radius * 1e3
    lo_mm, hi_mm = bracket_mm or (min(0.5 * a_max * 1e3, a_own) / 8, a_max * 1e3 * (1 - 1e-6))
    if not (0 < lo_mm < hi_mm < a_max * 1e3):
        raise SceneError(
            f"the radius bracket must satisfy 0 < low < high < {a_max * 1e3:.6g} mm (the largest radius whose "
            f"zones hold the closing pressure), got {lo_mm!r}..{hi_mm!r} mm",
            "bracket_mm",
        )

    if progress is not None and not callable(progress):
        raise SceneError(f"progress must be a callable (or None), got {type(progress).__name__}", "progress")

    def f(a_mm):
        trial = replace(scene, zone_radius=a_mm / 1e3)
        try:
            volts = transition_voltage(trial, kind, shared)[0]
        except CoexistError:
            if progress is not None:
                progress(a_mm, None)
            raise
        if progress is not None:
            progress(a_mm, volts)
        return volts - target_voltage

    top = a_max * 1e3
    budget = 6 * shared.settings.fit_samples
    tried: dict[float, float | None] = {}
    above: set[float] = set()  # radii whose transition lies above the top of the scene's path (so above the target)
    why: list[str] = []

    def value(a):
        if a not in tried and len(tried) < budget:
            try:
                tried[a] = f(a)
            except CoexistError as exc:
                tried[a] = None
                if isinstance(exc, ModelRangeError) and exc.above_top:
                    above.add(a)
                why.append(f"{a:.6g} mm: {exc}")
        return tried.get(a)

    def bracket():
        """Two neighbouring trial radii (none between them left out) whose transitions straddle the target."""
        order = sorted(tried)
        for a, b in zip(order[:-1], order[1:]):
            va, vb = tried[a], tried[b]
            if va is not None and vb is not None and va * vb <= 0:
                return a, b
        return next(((a, a) for a in order if tried[a] == 0), None)

    def solve(pair):
        a, b = pair
        if tried[a] == 0 or a == b:
            return a / 1e3
        if tried[b] == 0:
            return b / 1e3
        # converged in the voltage, |Φt(A) − Φtarget| ≤ rtol Φtarget, or where the radii run out of digits (a
        # tolerance in the radius would not do: near A_max the transition moves by 3e-5 V for 1e-9 mm)
        ftol = shared.settings.rtol * target_voltage
        root = bracketed_root(lambda x, _: np.array([f(float(x[0]))]), a, b, tried[a], tried[b], ftol=ftol)
        if not bool(root.converged.all()):
            raise SolverError(
                f"the fitted radius between {a:.9g} and {b:.9g} mm did not converge: the transition is "
                f"{float(root.f[0]):.3g} V from the target after {root.iterations} evaluations"
            )
        return float(root.x[0]) / 1e3

    # widen geometrically from the scene's own radius, both ways (see the docstring)
    start = min(max(a_own, lo_mm), hi_mm)
    value(start)
    paths = {+1: [start], -1: [start]}
    open_ = {+1: start < hi_mm, -1: start > lo_mm}
    k = 0
    while any(open_.values()) and len(tried) < budget:
        if (pair := bracket()) is not None:
            return solve(pair)
        for sign in (+1, -1):
            if not open_[sign]:
                continue
            a = paths[sign][-1]
            if sign > 0:  # never more than 3/4 of the way left to a_max: the radii crowd there
                nxt = min(a * np.exp(FIRST_STEP * 2**k), a + 0.75 * (top - a), hi_mm)
                open_[sign] = nxt < hi_mm
            else:
                nxt = max(a * np.exp(-FIRST_STEP * 2**k), lo_mm)
                open_[sign] = nxt > lo_mm
            nxt = float(nxt)
            paths[sign].append(nxt)
            if value(nxt) is None and any(tried.get(r) is not None for r in paths[sign][:-1]):
                open_[sign] = False  # the transition stopped existing on this side: beyond the band
            if (pair := bracket()) is not None:
                return solve(pair)
        k += 1
    # no bracket yet: resample between radii with and without a transition (where the transitions run
    # furthest), closer each round; if no radius had one, halve the widest gaps until one does
    rounds = 0
    while len(tried) < budget:
        order = sorted(tried)
        # a radius whose transition lies below the target next to one whose transition lies above the top of the
        # path (the zones stay homogeneous up to it) straddle the target: bisect between them until a radius with a
        # transition above the target brackets it (a target 10 V below the top of a 5 kV path: the transition moves
        # by 0.4 kV for 1 % of radius there, and three rounds of resampling had left the target unbracketed)
        below = {a for a, v in tried.items() if v is not None and v < 0}
        straddle = [(a, b) for a, b in zip(order[:-1], order[1:]) if {a, b} & below and {a, b} & above]
        if straddle:
            count = len(tried)
            for a, b in straddle:
                value(0.5 * (a + b))
                if (pair := bracket()) is not None:
                    return solve(pair)
            if len(tried) > count:
                continue  # (no new radius: the gap is down to the radius's resolution)
        if any(v is not None for v in tried.values()):
            edges = [(a, b) for a, b in zip(order[:-1], order[1:]) if (tried[a] is None) != (tried[b] is None)]
            if rounds == 3 or not edges:
                break
            rounds += 1
            new = [a + frac * (b - a) for a, b in edges for frac in (0.25, 0.5, 0.75)]
        else:
            new = [float(np.sqrt(a * b)) for a, b in zip(order[:-1], order[1:]) if np.log(b / a) > FILL_GAP]
            if not new:
                break
        for a in new:
            value(a)
            if (pair := bracket()) is not None:
                return solve(pair)
    values = [v for v in tried.values() if v is not None]
    reach = (
        f"transitions between {(min(values) + target_voltage) / 1e3:.4g} and "
        f"{(max(values) + target_voltage) / 1e3:.4g} kV"
        if values
        else f"no transition up to the scene's {top_volts / 1e3:.4g} kV"
    )
    raise ModelRangeError(
        f"no zone radius in {min(tried):.4g}..{max(tried):.4g} mm ({len(tried)} trial radii from the scene's "
        f"{a_own:.6g} mm; the zones hold the closing pressure below {top:.6g} mm) puts the {kind} transition "
        f"at {target_voltage / 1e3:.4g} kV: the radii give {reach}" + (f"; without one: {why[0]}" if why else ""),
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
        If the scene has no ``[chamber]``, or ``relative_change`` is not a number in ``(0, 1)``.
    """
    validation.scene(scene)
    if scene.chamber is None:
        raise SceneError("the sensitivity table needs a scene with a [chamber]", "[chamber]")
    relative_change = validation.real(relative_change, "relative_change", lo=0.0, lo_open=True)
    if relative_change >= 1:  # value·(1 − relative_change) would be a zero or negative radius, modulus, pressure ...
        raise SceneError(
            f"must lie in (0, 1) (each input is moved to value·(1 ± relative_change)), got {relative_change:g}",
            "relative_change",
        )
    if shared is not None and not isinstance(shared, Shared):
        raise SceneError(f"shared must be a Shared (Shared.of(scene)), got {type(shared).__name__}", "shared")
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
