"""From a scene to its answers: the pipeline assembled once, in physical units.

``scene → model (only the scene's effects) → the gas closed at the closing pressure (or a pressure
reservoir) → EquilibriumMap (stable segments of every configuration, traced on demand on the exact
equations) → ramp / coexistence table / fit``.

Everything in normalised form depends on the material alone (the scales ``μH/A``, ``A³``,
``H√(μ/ε)`` carry the geometry), so one model serves a whole fit and sensitivity study: changing
``A``, ``μ``, the chamber or the closing pressure only changes the gas and the voltage scale.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from . import validation
from .continuation import EquilibriumMap, Event, StableSegment, error_floor, relocate
from .effects import Breakdown, GasChamber, PressureReservoir, PressureSource
from .equilibria import Configuration, Equilibrium, zone_index_on_curve
from .errors import ModelRangeError, SceneError, SolverError, told_apart
from .model import MembraneModel
from .numerics.roots import newton
from .numerics.sets import unique_sorted
from .ramp import Ramp, RampResult, Transition, equal_free_energy, equal_free_energy_voltage
from .scene import Scene
from .settings import SolverSettings, tight_settings
from .shooting import StateDerivatives, solve_states


def zone_model(scene: Scene):
    """The model of one of ``scene``'s zones: :meth:`Scene.model`, or for patterned zones the
    :class:`~coexist.patterned.PatternedModel` that carries their pattern (every zone shot region by region, with
    exact derivatives; docs/physics.md section 12).

    Parameters
    ----------
    scene : Scene

    Returns
    -------
    MembraneModel
    """
    model = scene.model()
    if scene.patterned:
        from .patterned import PatternedModel

        model = PatternedModel.of(model, scene.zone_pattern())
    return model


def pole_stretch_max(scene: Scene, settings: SolverSettings | None = None) -> float:
    """Upper end of the zone curves of ``scene`` (:func:`stretch_range_end` of its material).

    Parameters
    ----------
    scene : Scene
        The scene; its material and prestretch are used.
    settings : SolverSettings, optional
        Supplies ``locking_margin`` and ``stretch_max_factor`` (default: :class:`SolverSettings`).

    Returns
    -------
    float
        The largest pole stretch ``λ0`` a zone is followed to.
    """
    return stretch_range_end(scene.elasticity(), scene.prestretch, settings)


def stretch_range_end(elasticity, prestretch: float, settings: SolverSettings | None = None) -> float:
    """Upper end of the pole stretches a zone is followed to: ``locking_margin`` times the material's
    equibiaxial locking stretch (:attr:`~coexist.effects.Gent.locking_stretch`), or ``stretch_max_factor``
    times the prestretch for a material that does not lock (:class:`~coexist.settings.SolverSettings`).

    Parameters
    ----------
    elasticity : NeoHookean or Gent
        The elasticity effect (:mod:`coexist.effects`); only its ``locking_stretch`` is used.
    prestretch : float
        Equibiaxial prestretch ``λpre``.
    settings : SolverSettings, optional
        Default: :class:`SolverSettings`.

    Returns
    -------
    float
        The largest pole stretch ``λ0``.

    Raises
    ------
    SceneError
        If ``locking_margin`` or ``stretch_max_factor`` leaves no pole stretch above ``1.002 λpre``.
    """
    settings = settings or SolverSettings()
    lock = elasticity.locking_stretch
    least = prestretch * (1 + 2e-3)  # the first pole stretch any grid of the library starts at
    if lock is not None:
        end = settings.locking_margin * lock
        if end <= least < lock:  # the margin, not the material, leaves no range (review, helper-62)
            raise SceneError(
                f"locking_margin = {settings.locking_margin:g} leaves no pole stretches to follow: the range ends at "
                f"λ0 = {end:.6g}, not above the prestretch {prestretch:g} (the material locks at {lock:.6g})",
                "locking_margin",
            )
        exact = getattr(elasticity, "exact_locking_stretch", None)
        if exact is not None:
            # `locking_stretch` drops the λ⁻⁴ of 2λ² + λ⁻⁴ − 3 = Jlim: at a small Jlim it lies far beyond where the
            # chains lock (Jlim 0.05: 1.235 against 1.068), and the margin times it too: the zone curves were laid
            # mostly on locked states, and a prestretch of 1.066 gave "no valid state anywhere in pole stretch
            # 1.068..1.173" (exit 1). The margin is then also taken of the exact stretch's excess over 1 (the end
            # stays the same where Jlim is large: 6.718 at Jlim 97)
            end = min(end, exact - (1 - settings.locking_margin) * (exact - 1))
            if end <= least:
                raise SceneError(
                    f"a prestretch of {prestretch:.6g} leaves no pole stretches to follow: a Gent membrane with "
                    f"jlim = {elasticity.jlim:g} locks at {exact:.6g} (equibiaxially), the states are followed up to "
                    f"{end:.6g}, and they start at 1.002 times the prestretch: the prestretch must be below "
                    f"{end / (1 + 2e-3):.6g}",
                    "prestretch",
                )
        return end
    if settings.stretch_max_factor * prestretch <= least:
        raise SceneError(
            f"stretch_max_factor must exceed 1.002 (the range ends at stretch_max_factor times the prestretch), "
            f"got {settings.stretch_max_factor:g}",
            "stretch_max_factor",
        )
    return settings.stretch_max_factor * prestretch


#: the snap-through search looks up to this many prestretches first (then to the end of the model's range)
SNAP_SEARCH_CAP = 12.0


def _numbers(value, name: str, sizes: tuple, what: str) -> tuple:
    """``value`` as a tuple of finite numbers of one of the ``sizes`` (the third of a snap may be a bool), else a
    SceneError naming ``name``."""
    if isinstance(value, (str, bytes)) or not hasattr(value, "__len__") or len(value) not in sizes:
        raise SceneError(f"{name} must be {what}, got {value!r}", name)
    head = tuple(validation.real(x, name) for x in value[:2])
    return head + tuple(value[2:])


class Snap(NamedTuple):
    """The largest pressure one zone holds at zero voltage: ``p_hat`` at ``pole_stretch``; ``maximum`` says
    whether it is a true pressure maximum (a snap-through) or, for a curve that rises to the end of the
    model's range (a stiff Gent material), the pressure at that end."""

    p_hat: float
    pole_stretch: float
    maximum: bool


def snap_through(model, settings: SolverSettings, lam_max: float) -> Snap:
    """``(p̂max, λ0)`` of one zone's first pressure maximum at zero voltage (solved exactly), or the
    largest pressure of the computed range and its pole stretch if the curve has no maximum.

    Parameters
    ----------
    model : MembraneModel
        The zone's model, evaluated at ``Φ̂ = 0``.
    settings : SolverSettings
        Tolerances; ``snap_grid_points`` pole stretches bracket the maximum first.
    lam_max : float
        Upper end of the pole-stretch grid (:func:`stretch_range_end`).

    Returns
    -------
    Snap
        ``(p̂max, λ0, maximum)``: the normalised pressure, the pole stretch at which it is reached, and
        whether it is a pressure maximum.
    """
    from .curves import pressure_volume_curve

    pre = model.prestretch
    curve = None
    # first up to SNAP_SEARCH_CAP λpre, where every snap-through lies (neo-Hookean: 2.2 λpre): a grid over a
    # range that reaches 1e10 (a Gent Jlim of 1e22) holds one valid state (review, helper-62)
    for top in dict.fromkeys((min(lam_max, SNAP_SEARCH_CAP * pre), lam_max)):
        grid = pre * (1 + np.linspace(np.sqrt(2e-3), np.sqrt(top / pre - 1), settings.snap_grid_points) ** 2)
        curve = pressure_volume_curve(model, 0.0, grid, settings)
        maxima = [lp for lp in curve.limit_points if lp.kind == "pressure_max"]
        if maxima:
            return Snap(float(maxima[0].p_hat), float(maxima[0].pole_stretch), True)
    assert curve is not None
    i = int(np.argmax(curve.states.p_hat))
    return Snap(float(curve.states.p_hat[i]), float(curve.states.pole_stretch[i]), False)


def closing_pressure(scene: Scene, snap: Snap) -> tuple[float, str]:
    """The normalised pressure the zones are closed in (the chamber's closing pressure) or held at (a controlled
    pressure), checked against the largest pressure one zone holds at zero voltage.

    Parameters
    ----------
    scene : Scene
        With a ``[chamber]`` or a controlled pressure.
    snap : Snap
        The zone's :func:`snap_through` at zero voltage.

    Returns
    -------
    p_hat : float
        The pressure ``p̂``, below ``snap.p_hat``: the closing state lies on the rising branch before the first
        pressure maximum, at ``λ0 < snap.pole_stretch``.
    field : str
        The scene field that sets it.

    Raises
    ------
    SceneError
        If the scene has neither, or the pressure is at or above ``snap.p_hat`` (naming the field).
    """
    if scene.chamber is not None:
        scene.check_closing_pressure(snap.p_hat, snap.maximum)
        return float(scene.p_hat(scene.chamber.closing_pressure)), scene.chamber.closing_pressure_field
    if scene.controlled_pressure is not None:
        p_close = float(scene.p_hat(scene.controlled_pressure))
        if not p_close < snap.p_hat:
            given, bound = told_apart(p_close, snap.p_hat)
            raise SceneError(
                f"the zones cannot hold {scene.controlled_pressure / 100:.4g} mbar (p̂ = {given}): it is at or "
                f"above their snap-through pressure p̂max = {bound}",
                scene.controlled_pressure_field,
            )
        return p_close, scene.controlled_pressure_field
    raise SceneError(
        "this computation needs a [chamber] (a gas the zones share) or a controlled pressure [zones].pressure_mbar",
        "[chamber]",
    )


def snap_through_pressure(scene: Scene, settings: SolverSettings | None = None) -> Snap:
    """The largest normalised pressure one zone of the scene holds at zero voltage (its ``p̂max``), and
    whether it is a snap-through (:class:`Snap`).

    Parameters
    ----------
    scene : Scene
        The scene; its material and prestretch are used, without electrostatics.
    settings : SolverSettings, optional
        Default: :class:`SolverSettings`.

    Returns
    -------
    Snap
        ``p̂max = pmax A/(μH)``, its pole stretch and whether it is a maximum (:func:`snap_through` up to
        :func:`pole_stretch_max`).
    """
    from .effects import NoElectrostatics
    from .model import MembraneModel

    base = scene.model()
    model = MembraneModel(base.elasticity, NoElectrostatics(), base.prestretch)
    settings = settings or SolverSettings()
    return snap_through(model, settings, pole_stretch_max(scene, settings))


def _distinct(segments: list) -> list:
    """The segments without those that repeat an earlier one: the same ends (kinds, and voltages within their
    errors) and the same state in the middle (:meth:`~coexist.continuation.StableSegment.matches`). At draft
    accuracy a seed near a pitchfork does not match its segment's loosely converged state there and is traced
    again: two zones listed their 1-of-2 range three times (review, helper-75)."""
    out: list = []
    for seg in segments:
        if not any(_same_segment(seg, kept) for kept in out):
            out.append(seg)
    return out


def _same_segment(a: StableSegment, b: StableSegment) -> bool:
    if a.configuration.counts != b.configuration.counts:
        return False
    rtol = a.tracer.system.settings.rtol
    for end_a, end_b, phi_a, phi_b in zip((a.low, a.high), (b.low, b.high), a.phi_range, b.phi_range):
        if getattr(end_a, "kind", None) != getattr(end_b, "kind", None):
            return False
        err = getattr(end_a, "error", 0.0) + getattr(end_b, "error", 0.0) + 2 * error_floor(phi_a, rtol)
        if abs(phi_a - phi_b) > err:
            return False
    middle = 0.5 * (b.phi_range[0] + b.phi_range[1])
    try:
        (state,) = b.states([middle])
    except SolverError:
        return False
    return a.matches(state)


#: :meth:`Simulation.discover` also seeds at this fraction of each known segment's range inside its ends
DISCOVERY_INSET = 1e-3


def _chamber_closed_at(scene: Scene, model, settings: SolverSettings, p_close: float, lam_c: float) -> GasChamber:
    """The scene's chamber gas closed at gauge pressure ``p̂`` with every zone at pole stretch ``λc`` (its volume
    shot with ``settings``)."""
    chamber = scene.chamber
    if chamber is None:
        raise SceneError("internal: a gas chamber for a scene without a [chamber]", "[chamber]")
    v_c = float(solve_states(model, [lam_c], 0.0, settings).v_hat[0])
    return GasChamber.closed_at(
        float(scene.v_hat(chamber.volume)),
        float(scene.p_hat(chamber.atmospheric_pressure)),
        p_close,
        scene.zone_count * v_c,
    )


def state_at_pressure(model, p_hat: float, settings: SolverSettings, lam_lo: float, lam_hi: float) -> float:
    """The pole stretch in ``(lam_lo, lam_hi)`` (a rising piece of the zero-voltage curve) at which one zone
    holds ``p̂``: Newton's method on exact states with exact derivatives, safeguarded by the bracket.

    Parameters
    ----------
    model : MembraneModel
        The zone's model, evaluated at ``Φ̂ = 0``.
    p_hat : float
        The normalised gauge pressure ``p̂`` to hold.
    settings : SolverSettings
        Tolerances of the shooting.
    lam_lo, lam_hi : float
        The bracket in pole stretch ``λ0``; ``p̂`` must lie between the pressures there.

    Returns
    -------
    float
        The pole stretch ``λ0``.

    Raises
    ------
    SceneError
        If the state at ``lam_lo`` is invalid or holds more than ``p̂`` (field ``pressure``).
    SolverError
        If a state inside the bracket is invalid or Newton's method does not converge.
    """
    lo, hi = float(lam_lo), float(lam_hi)
    s_lo = solve_states(model, [lo], 0.0, settings)
    if not s_lo.ok[0]:
        # no state just above the prestretch (a patterned zone can wrinkle there at tiny inflation): the search
        # starts at the first valid state of a batch between the two ends
        grid = lo + (hi - lo) * np.geomspace(1e-3, 0.5, 24)
        scan = solve_states(model, grid, 0.0, settings)
        if not scan.ok.any():
            from .shooting import reason_text

            raise SceneError(
                f"p̂ = {p_hat:.6g} cannot be placed on the zone's curve: no state exists from pole stretch {lo:.6g} "
                f"to {grid[-1]:.6g} at zero voltage ({reason_text(int(s_lo.status[0]))} at {lo:.6g})",
                "pressure",
            )
        first = int(np.argmax(scan.ok))
        lo, s_lo = float(grid[first]), solve_states(model, [grid[first]], 0.0, settings)
    if not s_lo.p_hat[0] <= p_hat:
        raise SceneError(f"p̂ = {p_hat:.6g} is below the smallest computed state (p̂ = {s_lo.p_hat[0]:.3g})", "pressure")

    def residual(x, _):
        st = solve_states(model, x, 0.0, settings, derivatives=True)
        if not st.ok[0]:
            raise SolverError(f"no valid state at pole stretch {x[0]:.8g} while solving for p̂ = {p_hat:.6g}")
        slope = StateDerivatives.of(st).dp_dl0
        return st.p_hat - p_hat, np.where(slope > 0, slope, np.nan)  # no rising slope: bisect the bracket

    root = newton(
        residual, 0.5 * (lo + hi), rtol=1e-14, lo=lo, hi=hi, sign_at_lo=-1.0, max_iter=60, stop_when_stalled=False
    )
    if not root.converged[0]:
        raise SolverError(f"the state at p̂ = {p_hat:.6g} did not converge")
    return float(root.x[0])


#: the most voltages :meth:`Simulation.discover` searches at (each shoots a whole zone curve, ``zone_curve_points``
#: states: 10 000 voltages are 2.4 million states, a minute; 10**6 ran out of memory)
MAX_DISCOVERY_VOLTAGES = 10_000


#: what :meth:`Simulation.branches` and :meth:`Simulation.measure_segment_ends` take, in words
_SEGMENT = "a StableSegment (report.result.segments)"


@dataclass
class Simulation:
    """A scene made ready to solve: model, what holds the pressure, and the map of its stable states.

    Build it with :meth:`from_scene`. ``phi_window`` is the voltage range the map is traced over (the
    scene's path, or a wider one for a fit); ``settings`` are the numerical choices of every solver.

    Attributes
    ----------
    scene : Scene
    settings : SolverSettings
    model : MembraneModel
        The one-zone model with the scene's effects.
    gas : GasChamber or PressureReservoir
        What holds the pressure: the chamber's gas closed at the closing pressure, or the controlled pressure.
    closing_stretch : float
        Pole stretch ``λ0`` of every zone when the valves close (0 V).
    p_hat_max : float
        Snap-through pressure ``p̂max`` of one zone at 0 V.
    lam_max : float
        Upper end of the zone curves' pole stretches (:func:`pole_stretch_max`).
    phi_window : tuple of float
        ``(Φ̂lo, Φ̂hi)``, the voltage range of the map.
    emap : EquilibriumMap
        The stable segments found so far, traced on demand.
    """

    scene: Scene
    settings: SolverSettings
    model: MembraneModel
    gas: PressureSource
    closing_stretch: float
    p_hat_max: float
    lam_max: float
    phi_window: tuple
    emap: EquilibriumMap
    _start: StableSegment | None = field(default=None, repr=False)
    _tight_gas: dict = field(default_factory=dict, repr=False)  # rtol -> the gas closed at it (_gas_at)

    @classmethod
    def from_scene(
        cls, scene: Scene, settings: SolverSettings | None = None, model=None, phi_window=None, snap=None
    ) -> Simulation:
        """Assemble a simulation of ``scene`` solved with ``settings`` (default: :class:`SolverSettings`).

        ``model`` and ``snap = (p̂max, λ0 at it)`` may be passed in when many scenes share one material
        (a fit); ``phi_window`` widens the voltage range the map is traced over.

        Parameters
        ----------
        scene : Scene
            The experiment; it needs a chamber or a controlled pressure.
        settings : SolverSettings, optional
            Default: :class:`SolverSettings`.
        model : MembraneModel, optional
            Default: ``scene.model()``.
        phi_window : tuple of float, optional
            ``(0, Φ̂hi)``, ``Φ̂hi ≥ 0`` (the map is traced from the closing state at 0 V); default ``(0, Φ̂ of the
            path's peak)``, ``(0, 0)`` without a voltage path.
        snap : tuple of float, optional
            ``(p̂max, λ0)`` of the zero-voltage pressure maximum; default: :func:`snap_through`.

        Returns
        -------
        Simulation
            Ready to ramp; nothing is traced yet.

        Raises
        ------
        SceneError
            If the zones cannot hold the closing (or controlled) pressure, or the scene has neither a
            chamber nor a controlled pressure (names the field), or ``phi_window`` is not ``(0, Φ̂hi ≥ 0)``, or
            its zones are patterned and ``model`` is given without their pattern (a patterned scene's own model is
            a :class:`~coexist.patterned.PatternedModel`). Also if that pressure is below the smallest computed
            state's.
        SolverError
            If the state at the closing pressure does not converge.

        Examples
        --------
        >>> from coexist import load_scene
        >>> sim = Simulation.from_scene(load_scene("tricircle"))
        >>> round(sim.p_hat_max, 4), round(sim.closing_stretch, 4)  # p̂max at 0 V, λ0 at 20 mbar
        (1.9727, 1.866)
        """
        settings = validation.settings_or_default(settings)
        validation.scene(scene)
        if model is not None:
            validation.membrane_model(model)
        snap = None if snap is None else _numbers(snap, "snap", (2, 3), "(p̂max, λ0 at it)")
        if phi_window is not None:  # a reversed window silently found nothing (review, helper-62)
            lo, hi = _numbers(phi_window, "phi_window", (2,), "(Φ̂lo, Φ̂hi)")
            if not (lo == 0 and hi >= 0):
                # a low end above 0 left the closing state (at 0 V) outside the window: its segment ended at once, and
                # the ramp over (0.1, 0.3) of the tricircle found no transition at all, silently
                raise SceneError(
                    f"phi_window must be (0, high) with high >= 0: the map is traced from the closing state at 0 V; "
                    f"got {phi_window!r}",
                    "phi_window",
                )
            phi_window = (lo, hi)
        if model is None:
            model = zone_model(scene)
        elif scene.patterned and getattr(model, "pattern", None) != scene.zone_pattern():
            scene.require_uniform("a Simulation with a model that does not carry the scene's pattern")
        lam_max = pole_stretch_max(scene, settings)
        if snap is None:  # at zero voltage a model with electrostatics gives the passive numbers (tested)
            snap = snap_through(model, settings, lam_max)
        p_max, lam_at_max = snap[0], snap[1]
        snaps = bool(snap[2]) if len(snap) > 2 else True
        if phi_window is None:
            path = scene.voltage_hat_path
            phi_window = (0.0, float(np.max(path)) if path is not None else 0.0)
        p_close, field_name = closing_pressure(scene, Snap(p_max, lam_at_max, snaps))
        lam_lo = model.prestretch * (1 + 2e-3)
        try:
            lam_c = state_at_pressure(model, p_close, settings, lam_lo, lam_at_max)
        except SceneError as exc:
            raise SceneError(f"{exc.message}; raise it", field_name) from None
        gas: PressureSource
        if scene.chamber is not None:
            gas = _chamber_closed_at(scene, model, settings, p_close, lam_c)
        else:
            gas = PressureReservoir(p_close)
        breakdown = None if scene.breakdown_field is None else Breakdown(scene.breakdown_field / scene.field_scale)
        emap = EquilibriumMap(model, gas, scene.zone_count, settings, phi_window, breakdown)
        return cls(scene, settings, model, gas, lam_c, p_max, lam_max, tuple(phi_window), emap)

    # ---------------------------------------------------------------------------------------------
    @property
    def start(self) -> StableSegment:
        """The homogeneous stable segment through the state the valves closed in (0 V)."""
        if self._start is None:
            u = math.sqrt(self.closing_stretch - self.model.prestretch)
            tr = self.emap.tracer((self.scene.zone_count,))
            seed = tr.seed(np.array([u, 0.0]))
            if not seed.stable:
                raise ModelRangeError("the state the valves closed in is not stable", "no_equilibrium")
            self._start = StableSegment(tr.trace(seed, stable_only=True), tr, self.emap.branches_of(seed.eq))
            self.emap.segments.append(self._start)
        return self._start

    def ramp(self, progress=None) -> RampReport:
        """The scene's voltage path, followed from the closing state (:class:`~coexist.ramp.Ramp`).

        With ``settings.error_estimates`` every transition's error is measured (:meth:`measure_errors`). Measured
        errors hold for ``rtol ≤ 1e-6`` (draft): looser, the sign of a tension near zero is lost in the shooting's
        error, and an event can move by far more than its error (the default scene at 1e-5: the wrinkling onset missed,
        the end 0.008 kV late against ± 1e-4). The command line refuses such tolerances for its event commands; the
        accuracy study runs them to show what looseness costs.

        Parameters
        ----------
        progress : callable, optional
            Called with the index of each voltage of the path once it is done.

        Returns
        -------
        RampReport
            The steps, transitions and equal-free-energy voltages, in physical units.

        Raises
        ------
        SceneError
            If the scene has no ``[voltage]``.
        ModelRangeError
            If the state the valves closed in is not stable.
        SolverError
            If an equal-free-energy voltage does not converge.
        """
        if progress is not None and not callable(progress):
            raise SceneError(f"progress must be a callable (or None), got {type(progress).__name__}", "progress")
        if self.scene.voltage is None:
            raise SceneError("this scene has no [voltage]: nothing to ramp", "[voltage]")
        path = self.scene.voltage_hat_path
        result = Ramp(self.emap, self.lam_max).run(path, self.start, progress)
        if path is not None and len(path) and path[0] > 0:
            # the state follows the voltage up from the closing state at 0 V: what happens below the first printed
            # voltage is part of the ramp (a transition there is listed, its states are not printed)
            result.notes.append(
                f"the ramp starts from the closing state at 0 V and passes the voltages below the path's first, "
                f"{self.scene.voltage_of(path[0]) / 1e3:.6g} kV, without printing their states (a transition there "
                "is listed)"
            )
        if self.settings.error_estimates:
            self.measure_errors(result.transitions + result.equal_free_energy)
        return RampReport(self.scene, self.settings, result, self.gas, self.scene.effects(), dict(self.scene.fitted))

    def branches(self, segments) -> list:
        """The whole branch of each segment's configuration through it (stable and unstable pieces, through
        folds, over the window): what a figure draws around the ramp. The segment as traced, continued past its
        ends where the branch goes on (:meth:`~coexist.continuation.Tracer.extend`). Tracing only; nothing
        reported.

        Parameters
        ----------
        segments : iterable of StableSegment
            E.g. ``report.result.segments`` of a ramp.

        Returns
        -------
        list of Branch
            One :class:`~coexist.continuation.Branch` per segment whose trace succeeds (failures are skipped).

        Raises
        ------
        SceneError
            If ``segments`` is not an iterable of StableSegment (None had been a raw TypeError).
        """
        out = []
        for seg in validation.instances(segments, StableSegment, "segments", _SEGMENT):
            try:
                out.append(seg.tracer.extend(seg.branch))
            except SolverError:
                continue
        return out

    def measure_errors(self, transitions) -> None:
        """Re-locate every transition at a tighter tolerance (``rtol/100``, at least 1e-13): its error is
        the change (plus its location bracket). In place.

        Parameters
        ----------
        transitions : list of Transition
            Their ``phi_hat_error`` and ``measured`` are updated. Equal-free-energy voltages are solved again
            with both states at the tighter tolerance; others are re-located from their continuation event
            (an event is measured once; transitions without one, and failed re-locations, keep their error).

        Raises
        ------
        SceneError
            If ``transitions`` is not an iterable of Transition.
        SolverError
            If an equal-free-energy voltage does not converge at the tighter tolerance.
        """
        transitions = validation.instances(
            transitions, Transition, "transitions", "a Transition (report.result.transitions)"
        )
        tight_map = self._tight_map()
        done = {}
        for t in transitions:
            if t.kind == "equal_free_energy":
                seg_a, seg_b = t.segments
                crossing = _tight_crossing(t, seg_a, seg_b, tight_map)
                floor = error_floor(t.phi_hat, self.settings.rtol)
                t.phi_hat_error = max(t.phi_hat_error, 0.0) + crossing + floor
                t.measured = True
                continue
            ev = getattr(t, "source", None)
            if not isinstance(ev, Event):
                continue
            if id(ev) not in done:
                self._measure_event(ev, t.source_counts, tight_map)
                done[id(ev)] = ev.error
            t.phi_hat_error = done[id(ev)]
            t.measured = ev.measured

    def _tight_map(self) -> EquilibriumMap:
        tight = tight_settings(self.settings)
        return EquilibriumMap(
            self.model, self._gas_at(tight), self.scene.zone_count, tight, self.phi_window, self.emap.breakdown
        )

    def _gas_at(self, settings: SolverSettings) -> PressureSource:
        """The scene's gas closed with the zones' volume at the closing pressure computed with ``settings``: the
        gas amount carries the error of that volume, and a transition located again at a tighter tolerance on
        the loose gas left it out of the measured error (Gent 300: 4× too small, review helper-73; the
        transitions move by ~60–85 kV per unit relative change of the gas amount). The closing state is found
        again within ``1e-3 (λc − λpre)`` of the loose one; where it is not, and under pressure control, the
        loose gas."""
        if self.scene.chamber is None or not isinstance(self.gas, GasChamber):
            return self.gas
        if settings.rtol not in self._tight_gas:  # once per tolerance: every measurement of errors asks for it
            self._tight_gas[settings.rtol] = self._closed_gas(settings)
        return self._tight_gas[settings.rtol]

    def _closed_gas(self, settings: SolverSettings) -> PressureSource:
        """:meth:`_gas_at` computed (the scene has a chamber)."""
        chamber = self.scene.chamber
        if chamber is None:
            return self.gas
        lam_c, pre = self.closing_stretch, self.model.prestretch
        width = 1e-3 * (lam_c - pre)
        p_close = float(self.scene.p_hat(chamber.closing_pressure))
        try:
            lam = state_at_pressure(self.model, p_close, settings, lam_c - width, lam_c + width)
            return _chamber_closed_at(self.scene, self.model, settings, p_close, lam)
        except (SceneError, SolverError):
            return self.gas

    def _measure_event(self, ev: Event, counts, tight_map) -> None:
        if ev.measured or ev.kind == "window":
            return
        tr = self.emap.tracer(counts)
        try:
            relocate(ev, tr, tight_map.tracer(tr.system.configuration.counts))
        except SolverError:
            pass

    def measure_segment_ends(self, segments) -> None:
        """Measure the error of every event that ends one of ``segments`` (in place).

        Parameters
        ----------
        segments : iterable of StableSegment
            Their end events get ``error`` and ``measured`` updated (:func:`~coexist.continuation.relocate`).

        Raises
        ------
        SceneError
            If ``segments`` is not an iterable of StableSegment.
        """
        segments = validation.instances(segments, StableSegment, "segments", _SEGMENT)
        tight_map = self._tight_map()
        for seg in segments:
            for ev in (seg.low, seg.high):
                if isinstance(ev, Event):
                    self._measure_event(ev, seg.tracer.system.configuration.counts, tight_map)

    # ---------------------------------------------------------------------------------------------
    def discover(self, bulged=None, voltages: int | None = None) -> None:
        """Seed the map with every stable equilibrium found at ``voltages`` voltages (default: the settings'
        ``discovery_voltages``) across the window, and just inside both ends of every segment already traced
        (first guesses on zone curves shot at each voltage, then converged exactly; each new one is
        traced). Configurations: homogeneous and ``(N − k, k)`` for ``k`` in ``bulged``.

        The segment ends matter where a configuration is stable only on a narrow range between the ends of
        others: two zones under pressure control are independent, and one bulged with one unbulged is stable
        exactly where both states of a zone are (4.3144–4.4619 kV in one scene), which 13 voltages 0.5 kV apart
        missed ("never stable", while the ramp's two homogeneous segments gave its equal free energy: review,
        helper-74).

        Parameters
        ----------
        bulged : iterable of int, optional
            Numbers ``k`` of bulged zones, each in ``1..N−1``; default ``1..N−1``.
        voltages : int, optional
            Number of voltages, evenly spaced over :attr:`phi_window` (one if the window is a single voltage), a
            whole number in ``1..MAX_DISCOVERY_VOLTAGES``.

        Raises
        ------
        SceneError
            If a number of bulged zones is not a whole number in ``1..N−1`` (field ``bulged``), or ``voltages`` is
            not a whole number in ``1..MAX_DISCOVERY_VOLTAGES`` (field ``voltages``).
        """
        from .candidates import candidate_equilibria
        from .zone_curves import ZoneCurve

        # checked like equilibria_at's (a bare number, text, or k outside 1..N-1 was a raw TypeError/ValueError or
        # silently nothing), and the voltages a whole number: -1 or 2.5 were numpy errors, 10**6 shot 240 million
        # states (minutes, then the machine's memory) before anything was refused
        if bulged is not None and not (hasattr(bulged, "__len__") and len(bulged) == 0):  # [] (one zone): none
            bulged = self._bulged_counts(bulged)
        if voltages is None:
            voltages = self.settings.discovery_voltages
        voltages = validation.integer(voltages, "voltages", lo=1, hi=MAX_DISCOVERY_VOLTAGES)
        lo, hi = self.phi_window
        pre = self.model.prestretch
        u = np.linspace(np.sqrt(1e-3 * pre), np.sqrt(self.lam_max - pre), self.settings.zone_curve_points)
        phis = np.linspace(lo, hi, voltages) if hi > lo else np.array([lo])
        if hi > lo:
            ends = [
                x
                for a, b in (seg.phi_range for seg in self.emap.segments)
                if b > a
                for x in (a + DISCOVERY_INSET * (b - a), b - DISCOVERY_INSET * (b - a))
            ]
            phis = unique_sorted(np.r_[phis, [x for x in ends if lo <= x <= hi]])
        st = solve_states(self.model, np.tile(pre + u**2, phis.size), np.repeat(phis, u.size), self.settings)
        n = u.size
        for i, phi in enumerate(phis):
            from .curves import _take

            try:
                curve = ZoneCurve.from_states(_take(st, slice(i * n, (i + 1) * n)), phi, pre)
            except ModelRangeError:
                continue
            for cand in candidate_equilibria(
                curve, self.gas, self.scene.zone_count, bulged, self.settings.candidate_samples
            ):
                eq = converge_candidate(self.emap, cand, curve)
                if eq is None:
                    continue
                if not eq.stable or self.emap.find(eq) is not None:
                    continue
                try:
                    self.emap.segment_of(eq, eq.zone_index)
                except SolverError:
                    continue

    def equilibria_at(self, phi: float = 0.0, bulged=None) -> list[Equilibrium]:
        """Every equilibrium (stable or not) at one voltage on the scene's gas (:func:`equilibria_on_gas`).

        Parameters
        ----------
        phi : float
            The normalised voltage ``Φ̂``.
        bulged : iterable of int, optional
            Numbers ``k`` of bulged zones, each in ``1..N−1``; default ``1..N−1``.

        Returns
        -------
        list of Equilibrium
            Sorted by the number of bulged zones, then by free energy ``Ĝ``.

        Raises
        ------
        SceneError
            If a number of bulged zones is not a whole number in ``1..N−1`` (field ``bulged``).
        """
        ks = None if bulged is None else self._bulged_counts(bulged)
        return equilibria_on_gas(
            self.model, self.gas, self.scene.zone_count, phi, self.settings, self.lam_max, ks, self.emap
        )

    def _bulged_counts(self, bulged) -> list[int]:
        """The numbers ``k`` of bulged zones asked for (``None``: ``1..N−1``), each a whole number in ``1..N−1``;
        a single number is taken as a list of one (review, helper-62: ``bulged=[5]`` on three zones listed only
        the homogeneous state, ``bulged=1`` raised a TypeError)."""
        N = self.scene.zone_count
        if bulged is None:
            return list(range(1, N))
        if N < 2:
            raise SceneError("one zone has no coexistence: there is no number of bulged zones to list", "bulged")
        if isinstance(bulged, str) or not hasattr(bulged, "__iter__"):
            bulged = [bulged]
        # 0 and N are the homogeneous states (their own configurations), not coexistence
        return sorted({validation.integer(k, "bulged", lo=1, hi=N - 1) for k in bulged})

    def coexistence(self, bulged=None) -> list[CoexistenceEntry]:
        """For each ``k`` in ``bulged`` (default ``1..N−1``): the stable segments of ``k`` bulged zones
        (ranges with their exact ends) and the voltages where they have the free energy of the
        homogeneous state, or two of them (branches of the configuration) each other's, with the coexisting
        states there.

        Every segment a slow ramp over :attr:`phi_window` (up and back, unless the window is one voltage)
        reaches is traced first, then :meth:`discover` seeds the others. A jump of that ramp that finds no
        landing (a :class:`SolverError`) stops it without ending this: the segments traced before it stay,
        and every entry's ``note`` names the failure (the ``ramp`` command still reports it as an error). An
        entry with stable segments but no equal free energy says why in its ``note``.

        Parameters
        ----------
        bulged : iterable of int, optional
            Numbers ``k`` of bulged zones, each in ``1..N−1``; default ``1..N−1``.

        Returns
        -------
        list of CoexistenceEntry
            One per ``k``, in increasing order.

        Raises
        ------
        SceneError
            If a number of bulged zones is not a whole number in ``1..N−1`` (field ``bulged``).
        ModelRangeError
            If the state the valves closed in is not stable.
        SolverError
            If an equal-free-energy voltage does not converge.
        """
        N = self.scene.zone_count
        ks = self._bulged_counts(bulged)
        # every segment a slow ramp can reach (up to the top of the window and back) ...
        # (a jump that finds no landing stops that ramp: the segments traced before it stay in the map, the
        # discovery below seeds the others, and every entry's note says what the ramp did not reach)
        unreached = None
        if self.phi_window[1] > self.phi_window[0]:
            try:
                Ramp(self.emap, self.lam_max).run([self.phi_window[1], self.phi_window[0]], self.start)
            except SolverError as exc:
                unreached = (
                    f"the ramp over the window stopped ({exc}): the stable states past that jump were found only "
                    "by seeding at discrete voltages, and a segment that none of them lies on is missing"
                )
        # ... and every other one the first guesses find
        self.discover(ks)
        # the homogeneous state the valves closed in (other homogeneous ones, e.g. all zones bulged
        # under pressure control, are configurations of their own)
        homog = [s for s in self.emap.segments if s.label == "homogeneous"]
        out = []
        for k in ks:
            segs = _distinct(
                sorted(
                    (s for s in self.emap.segments if s.configuration.counts == (N - k, k)),
                    key=lambda s: s.phi_range[0],
                )
            )
            crossings = equal_free_energy(homog + segs)
            labels = {s.label for s in segs}
            # against the homogeneous state, and between two branches of this configuration (two zone-curve pieces of
            # the bulged zones, both stable at one voltage: the ramp jumps between them; review, helper-77: two
            # zones' 3.997852120 kV was in the ramp only)
            crossings = [
                c
                for c in crossings
                if ("homogeneous" in (c.from_label, c.to_label) and {c.from_label, c.to_label} & labels)
                or (c.from_label == c.to_label and c.from_label in labels)
            ]
            if self.settings.error_estimates:
                self.measure_errors(crossings)
                self.measure_segment_ends(segs)
            note = (
                None
                if segs
                else f"no stable state with {k} of {N} zones bulged between "
                f"{self.scene.voltage_of(self.phi_window[0]) / 1e3:.4g} and "
                f"{self.scene.voltage_of(self.phi_window[1]) / 1e3:.4g} kV"
            )
            if segs and homog and not any("homogeneous" in (c.from_label, c.to_label) for c in crossings):
                note = self._no_equal_free_energy(homog, segs)
            if unreached is not None:
                note = unreached if note is None else f"{note}; {unreached}"
            out.append(CoexistenceEntry(k, segs, crossings, note))
        return out

    def _no_equal_free_energy(self, homog, segs) -> str:
        """Why stable ``segs`` of a configuration have no equal free energy with the homogeneous segments
        ``homog``: they are never stable at one voltage together, or where they are, their free energies do not
        cross (:func:`~coexist.ramp.equal_free_energy` found no sign change of ``ΔĜ`` over the overlap)."""
        kv = lambda phi: f"{self.scene.voltage_of(phi) / 1e3:.6g} kV"  # noqa: E731
        overlaps = [
            (max(a.phi_range[0], b.phi_range[0]), min(a.phi_range[1], b.phi_range[1])) for a in homog for b in segs
        ]
        # a common end (a configuration that branches from the homogeneous state at its split) is no overlap
        overlaps = [(lo, hi) for lo, hi in overlaps if hi - lo > 1e-8 * max(abs(hi), 1e-3)]
        if not overlaps:
            ranges = lambda group: ", ".join(f"{kv(s.phi_range[0])} to {kv(s.phi_range[1])}" for s in group)  # noqa: E731
            return (
                "no equal free energy with the homogeneous state: the two are never stable at one voltage (the "
                f"homogeneous state from {ranges(homog)}, {segs[0].label} from {ranges(segs)})"
            )
        where = ", ".join(f"{kv(lo)} to {kv(hi)}" for lo, hi in overlaps)
        return (
            f"no equal free energy with the homogeneous state: where both are stable ({where}) their free "
            "energies do not cross"
        )

    def first_transition(self, kind: str = "spinodal") -> Transition:
        """The first change on the way up from the closing state: where the homogeneous state is lost
        (``spinodal``: its first stability loss) or where one bulged zone first has its free energy
        (``equal_free_energy``).

        Parameters
        ----------
        kind : {"spinodal", "equal_free_energy"}
            Which transition.

        Returns
        -------
        Transition
            Its voltage ``Φ̂`` and error (measured when ``settings.error_estimates``).

        Raises
        ------
        ModelRangeError
            If there is none in :attr:`phi_window` (reason ``no_transition``): the homogeneous state stays
            stable up to the window's end, a range end or breakdown, or no one-bulged state reaches its free
            energy; or if the state the valves closed in is not stable.
        SceneError
            If ``kind`` is unknown, or the scene has no ``[voltage]`` (no voltage to look along).
        """
        if self.scene.voltage is None:  # its window is the one voltage 0: it had said "homogeneous up to 0 kV"
            raise SceneError(
                "this scene has no [voltage]: there is no voltage path to find a transition on", "[voltage]"
            )
        start = self.start
        end = start.end(+1)
        if kind == "spinodal":
            if not isinstance(end, Event) or end.kind in ("window", "range_end", "breakdown"):
                window = not isinstance(end, Event) or end.kind == "window"
                why = "the window ends" if window else end.note
                raise ModelRangeError(
                    f"the zones stay homogeneous up to {self.scene.voltage_of(start.end_phi(+1)) / 1e3:.6g} kV ({why})",
                    "no_transition",
                    above_top=window,
                )
            t = Transition(
                end.phi_hat,
                "spinodal",
                "homogeneous",
                "",
                "up",
                end.kind,
                end.error,
                source=end,
                source_counts=start.tracer.system.configuration.counts,
            )
            if self.settings.error_estimates:
                self.measure_errors([t])
            return t
        if kind == "equal_free_energy":
            N = self.scene.zone_count
            # one zone: its bulged state is the homogeneous one on another branch of the zone curve (the state the
            # jump lands on); several: one bulged zone beside N − 1 unbulged ones
            one = (N - 1, 1) if N > 1 else (1,)
            # the segment the ramp's first jump lands on is usually the one-bulged one; if not, search
            if isinstance(end, Event) and end.kind in ("split", "fold"):
                try:
                    Ramp(self.emap, self.lam_max).jump(start, end, +1)
                except SolverError:
                    pass
            label = Configuration(one).label if N > 1 else "the bulged state"

            def crossings():
                segs = [s for s in self.emap.segments if s.configuration.counts == one and s is not start]
                if N == 1:
                    labels = {s.label for s in segs} - {start.label}
                    return [
                        c
                        for c in equal_free_energy([start] + segs)
                        if c.from_label == start.label
                        and c.to_label in labels
                        or c.to_label == start.label
                        and c.from_label in labels
                    ]
                return [
                    c for c in equal_free_energy([start] + segs) if {c.from_label, c.to_label} == {"homogeneous", label}
                ]

            found = crossings()
            if not found and N > 1:
                self.discover([1])
                found = crossings()
            if not found:
                raise ModelRangeError(
                    f"no voltage up to {self.scene.voltage_of(self.phi_window[1]) / 1e3:.6g} kV at "
                    f"which {label} has the free energy of the homogeneous state",
                    "no_transition",
                )
            if self.settings.error_estimates:
                self.measure_errors(found[:1])
            return found[0]
        raise SceneError(f"unknown transition kind {kind!r}; use 'spinodal' or 'equal_free_energy'", "kind")


def equilibria_on_gas(
    model,
    gas,
    zones: int,
    phi: float,
    settings: SolverSettings,
    lam_max: float,
    bulged=None,
    emap: EquilibriumMap | None = None,
) -> list[Equilibrium]:
    """Every equilibrium (stable or not) of the homogeneous and the ``(N − k, k)`` configurations of ``zones``
    zones on ``gas`` at one voltage ``Φ̂``.

    First guesses come from the zone curve shot at ``Φ̂`` (:func:`coexist.candidates.candidate_equilibria`);
    each is converged on the exact equations, its Hessian's eigenvalues are in closed form and each
    zone's own index is counted on the curve. Next to a fold Newton's method finds one state of the
    pair (or none): from every candidate (or the state it converged to) the partners predicted by
    :func:`fold_partner_guesses` are converged too. States that converge onto a coarser configuration
    are dropped (that configuration is found on its own), as are duplicates.

    Parameters
    ----------
    model : MembraneModel
        The one-zone model.
    gas : GasChamber or PressureReservoir
        What holds the pressure (:class:`~coexist.effects.PressureSource`).
    zones : int
        Number ``N`` of identical zones.
    phi : float
        The normalised voltage ``Φ̂``.
    settings : SolverSettings
        Tolerances and sample counts.
    lam_max : float
        Upper end of the zone curve's pole stretches.
    bulged : iterable of int, optional
        Numbers ``k`` of bulged zones; default ``1..N−1``.
    emap : EquilibriumMap, optional
        The map whose tracers converge the candidates; default a new one over ``(Φ̂, Φ̂)``.

    Returns
    -------
    list of Equilibrium
        Sorted by the number of bulged zones, then by free energy ``Ĝ``.
    """
    from .candidates import Candidate, candidate_equilibria
    from .zone_curves import ZoneCurve

    validation.membrane_model(model)
    validation.has_methods(
        gas, ("pressure", "stiffness", "free_energy"), "gas", "a pressure source (GasChamber, PressureReservoir)"
    )
    zones = validation.integer(zones, "zones", lo=1, hi=1000)
    phi = validation.real(phi, "phi", lo=0.0)
    settings = validation.settings_or_default(settings)
    lam_max = validation.real(lam_max, "lam_max", lo=model.prestretch, lo_open=True)
    emap = emap or EquilibriumMap(model, gas, zones, settings, (phi, phi))
    pre = model.prestretch
    u = np.linspace(np.sqrt(1e-3 * pre), np.sqrt(lam_max - pre), settings.zone_curve_points)
    curve = ZoneCurve.compute(model, phi, pre + u**2, settings)
    out: list[Equilibrium] = []

    def keep(eq):
        if eq is None or any(
            e.configuration == eq.configuration and np.allclose(e.pole_stretch, eq.pole_stretch, rtol=1e-7) for e in out
        ):
            return
        out.append(eq)

    for cand in candidate_equilibria(curve, gas, zones, bulged, settings.candidate_samples):
        eq = converge_candidate(emap, cand, curve)
        keep(eq)
        # next to a fold Newton finds one state of the pair (or none): look for the other along the soft direction
        u0 = np.asarray(cand.u, dtype=float) if eq is None else np.sqrt(np.asarray(eq.pole_stretch) - pre)
        for guess in fold_partner_guesses(emap.tracer(cand.counts).system, u0, phi):
            keep(converge_candidate(emap, Candidate(cand.counts, tuple(float(x) for x in guess), phi), curve))
    return sorted(out, key=lambda e: (e.configuration.bulged, e.free_energy))


# heuristic threshold: the largest step (in u = √(λ0 − λpre), along the soft direction) to which the
# quadratic fold model of fold_partner_guesses is trusted; farther partners are the curve's own candidates
FOLD_STEP_MAX = 0.05


def fold_partner_guesses(system, u, phi: float) -> list[np.ndarray]:
    """First guesses of the equilibria of a pair next to a fold, from a quadratic model at ``u``.

    Next to a fold the Jacobian ``J = ∂r/∂u`` (at fixed ``Φ̂``) has a small singular value ``σ`` with
    right and left singular vectors ``v``, ``w``; the two states of the pair lie about
    ``√(Φ̂ − Φ̂fold)`` apart along ``v``, so Newton's method from one guess finds one of them (or
    fails). Writing ``δ = s v + Σk tk Vk`` (``Vk``, ``Uk``, ``Sk``: the other singular triplets),
    ``r(u + δ) ≈ 0`` gives ``tk = −Uk·r / Sk`` and, along ``w``,

        ``w·r + σ s + ½ g2 s² = 0``,   ``g2 = d(w·J v)/ds``,

    ``g2`` by a difference of the Jacobian at ``u + h v`` (``h = 1e-4``). Each real root ``s`` with
    ``1e-9 < |s| ≤`` :data:`FOLD_STEP_MAX` (heuristic threshold) gives a guess; at a converged state
    (``r = 0``) that is the mirror image ``s = −2σ / g2`` of the state across the fold. Guesses only:
    each is converged on the exact equations by the caller.

    Parameters
    ----------
    system : GroupSystem
        The configuration's equations.
    u : array_like, shape (M,)
        ``u = √(λ0 − λpre)`` of each group: a converged state or a first guess.
    phi : float
        The voltage ``Φ̂``.

    Returns
    -------
    list of numpy.ndarray
        Zero, one or two guesses of ``u``.
    """
    u = np.asarray(u, dtype=float)
    M = u.size
    h = 1e-4
    res = system.residual(u[None, :], np.array([phi]), derivatives=True)
    if not (res.states.ok[0] and np.all(np.isfinite(res.J[0, :, :M])) and np.all(np.isfinite(res.r[0]))):
        return []
    U, S, Vt = np.linalg.svd(res.J[0, :, :M])
    v, w, sigma = Vt[-1], U[:, -1], S[-1]
    res_h = system.residual((u + h * v)[None, :], np.array([phi]), derivatives=True)
    if not (res_h.states.ok[0] and np.all(np.isfinite(res_h.J[0, :, :M]))):
        return []
    g2 = (w @ res_h.J[0, :, :M] @ v - sigma) / h
    g0 = w @ res.r[0]
    disc = sigma**2 - 2.0 * g2 * g0
    if not (np.isfinite(disc) and disc >= 0.0 and g2 != 0.0):
        return []
    perp = u - sum((((U[:, k] @ res.r[0]) / S[k]) * Vt[k] for k in range(M - 1)), np.zeros(M))
    out = []
    for s in ((-sigma + np.sqrt(disc)) / g2, (-sigma - np.sqrt(disc)) / g2):
        if 1e-9 < abs(s) <= FOLD_STEP_MAX:
            out.append(perp + s * v)
    return out


def converge_candidate(emap: EquilibriumMap, cand, curve) -> Equilibrium | None:
    """The exact equilibrium a first guess (:class:`~coexist.candidates.Candidate`) converges to at its
    voltage, with each zone's index counted on ``curve``; None if Newton fails or the groups collapse onto
    a coarser configuration (that one is found on its own).

    Parameters
    ----------
    emap : EquilibriumMap
        Supplies the tracer of the candidate's configuration and the settings.
    cand : Candidate
        Group sizes, ``u = √(λ0 − λpre)`` per group and ``Φ̂``.
    curve : ZoneCurve
        The zone curve at the candidate's voltage, on which each zone's index is counted.

    Returns
    -------
    Equilibrium or None
        The converged equilibrium, or None.
    """
    from .continuation import solve_at_voltage
    from .equilibria import make_equilibrium

    tr = emap.tracer(cand.counts)
    M = len(cand.counts)
    corr = solve_at_voltage(tr, np.concatenate([cand.u, [0.0]]), cand.phi_hat)
    if not corr.ok[0] or np.any(np.diff(np.sort(corr.z[0, :M])) < 1e-6):
        return None
    eq = make_equilibrium(tr.system, corr.res, corr.rows[0])
    eq.zone_index = tuple(zone_index_on_curve(curve, x, emap.settings) for x in np.sort(corr.z[0, :M]))
    return eq


def _tight_crossing(t: Transition, A: StableSegment, B: StableSegment, tight_map: EquilibriumMap) -> float:
    """The change of an equal-free-energy voltage when both states are converged at the tighter tolerance."""
    from .continuation import solve_at_voltage
    from .equilibria import make_equilibrium

    def tight_state(seg, phi):
        tr = tight_map.tracer(seg.configuration.counts)
        corr = solve_at_voltage(tr, seg.predict(phi), phi, chord=True)
        if not corr.ok[0]:
            raise SolverError(f"{seg.label}: no state at Φ̂ = {phi:.10g} at the tighter tolerance")
        return make_equilibrium(tr.system, corr.res, corr.rows[0])

    lo = max(A.phi_range[0], B.phi_range[0])
    hi = min(A.phi_range[1], B.phi_range[1])
    phi, step, _, _ = equal_free_energy_voltage(
        lambda x: tight_state(A, x), lambda x: tight_state(B, x), t.phi_hat, lo, hi, tight_map.settings
    )
    # twice the change (the tighter value has noise of its own), and the last step, which the tight
    # states still leave open
    return 2 * abs(phi - t.phi_hat) + abs(step)


@dataclass
class CoexistenceEntry:
    """What is known of the configuration with ``k`` bulged zones: its stable segments and its
    equal-free-energy voltages against the homogeneous state.

    Attributes
    ----------
    k : int
        Number of bulged zones.
    segments : list of StableSegment
        Its stable segments, by increasing voltage.
    crossings : list of Transition
        Its equal-free-energy voltages against the homogeneous state, and between two of its branches (segments of
        one configuration on different pieces of the zone curve, stable at one voltage: ``from_label ==
        to_label``).
    note : str or None
        Why there is no stable segment in the window, or why its stable segments have no equal free energy with
        the homogeneous state (never stable at one voltage together, or their free energies do not cross where
        they are); and what the preliminary ramp did not reach if a jump of it failed; None otherwise.
    """

    k: int
    segments: list
    crossings: list
    note: str | None = None


@dataclass
class RampReport:
    """A ramp in physical units, ready for tables, JSON and figures.

    Attributes
    ----------
    scene : Scene
    settings : SolverSettings
    result : RampResult
        The ramp in normalised units.
    gas : GasChamber or PressureReservoir
        What held the pressure.
    effects : list of str
        The scene's effects (:meth:`Scene.effects`).
    fitted : dict
        The scene's notes of fitted parameters.
    """

    scene: Scene
    settings: SolverSettings
    result: RampResult
    gas: object
    effects: list
    fitted: dict = field(default_factory=dict)

    def voltage_kV(self, phi_hat):
        """Voltage in kV of a normalised voltage, ``Φ = Φ̂ H √(μ/ε)``.

        Parameters
        ----------
        phi_hat : float or array_like
            Normalised voltage ``Φ̂`` (or an error of one).

        Returns
        -------
        float or numpy.ndarray
            ``Φ`` in kV.
        """
        return self.scene.voltage_of(phi_hat) / 1e3

    def pressure_mbar(self, p_hat):
        """Gauge pressure in mbar of a normalised pressure, ``p = p̂ μH/A``.

        Parameters
        ----------
        p_hat : float or array_like
            Normalised gauge pressure ``p̂``.

        Returns
        -------
        float or numpy.ndarray
            ``p`` in mbar.
        """
        return self.scene.pressure(p_hat) / 100

    def volume_ml(self, v_hat):
        """Volume in ml of a normalised volume, ``V = V̂ A³``.

        Parameters
        ----------
        v_hat : float or array_like
            Normalised volume ``V̂``.

        Returns
        -------
        float or numpy.ndarray
            ``V`` in ml.
        """
        return self.scene.volume(v_hat) * 1e6

    def transition_dict(self, t: Transition) -> dict:
        """One transition, JSON-ready, in kV.

        Parameters
        ----------
        t : Transition
            A transition or an equal-free-energy voltage of :attr:`result`.

        Returns
        -------
        dict
            ``voltage_kV``, ``voltage_error_kV``, ``error_measured``, ``from``, ``to``, ``kind``, ``event``,
            ``direction``, ``reason`` and, when the transition has one, ``mode``.
        """
        return {
            "voltage_kV": float(self.voltage_kV(t.phi_hat)),
            "voltage_error_kV": float(self.voltage_kV(t.phi_hat_error)),
            "error_measured": bool(getattr(t, "measured", False)),
            "from": t.from_label,
            "to": t.to_label,
            "kind": t.kind,
            "event": t.event,
            "direction": t.direction,
            "reason": t.reason,
            **({"mode": t.mode} if t.mode else {}),
        }

    def state_dict(self, st: Equilibrium | None) -> dict:
        """One state of the zones, JSON-ready, in mbar and ml.

        Parameters
        ----------
        st : Equilibrium or None
            The state, or None where the path has none.

        Returns
        -------
        dict
            ``pressure_mbar``, ``zone_volumes_ml`` and ``pole_stretches`` (per zone, least inflated first),
            ``groups`` (the same per group of identical zones: ``zones``, ``volume_ml``, ``pole_stretch``; its
            size does not grow with the number of zones), ``configuration``, ``bulged_zones``, ``stable`` and
            ``residual_p_hat``; ``state_notes`` where the state carries notes (e.g. taken at a branch point within
            its uncertainty); for a tension-field scene ``wrinkled_area_fraction`` (per zone, the reference
            area fraction of its hoop-wrinkled region); without a state the values are None, ``"none"`` and
            False, and there is no ``residual_p_hat``.
        """
        if st is None:
            return {
                "pressure_mbar": None,
                "zone_volumes_ml": None,
                "pole_stretches": None,
                "groups": None,
                "configuration": "none",
                "bulged_zones": None,
                "stable": False,
            }
        return {
            "pressure_mbar": float(self.pressure_mbar(st.p_hat)),
            "zone_volumes_ml": [float(self.volume_ml(v)) for v in st.zone_volumes],
            "pole_stretches": [float(x) for x in st.zone_pole_stretches],
            "groups": [
                {"zones": int(n), "volume_ml": float(self.volume_ml(v)), "pole_stretch": float(lam)}
                for n, v, lam in zip(st.configuration.counts, st.v_hat, st.pole_stretch)
            ],
            "configuration": st.label,
            "bulged_zones": st.k,
            "stable": bool(st.stable),
            "residual_p_hat": float(st.residual),
            **({"state_notes": list(st.notes)} if st.notes else {}),
            **(
                {
                    "wrinkled_area_fraction": [
                        float(x) for x, n in zip(st.wrinkled_fraction, st.configuration.counts) for _ in range(n)
                    ]
                }
                if st.wrinkled_fraction
                else {}
            ),
        }

    def to_dict(self, every: int = 1, shapes: bool = False, shape_points: int = 0) -> dict:
        """The whole report, JSON-ready.

        Parameters
        ----------
        every : int, optional
            Keep every ``every``-th voltage of the path (default all), and always the first, the last and
            each where the configuration changes.
        shapes : bool, optional
            Add to every kept step ``shapes``: per group of identical zones (as ``groups``) its ``zones`` and
            the shape of :meth:`coexist.shapes.Profile.to_dict` (apex height, apex curvature, radius of
            curvature, electrode edge, wrinkled intervals; None without a state), all states of the ramp
            profiled at once (:func:`coexist.shapes.profiles`; a hoop-wrinkled state too, its profile through
            the band on the relaxed equations).
        shape_points : int, optional
            With ``shapes``: also each zone's profile with this many points (``profile``: ``r_mm``,
            ``z_mm``); 0 (default) for none, else at least 3.

        Returns
        -------
        dict
            ``scene`` (:meth:`Scene.to_dict`), ``effects``, ``fitted_parameters``, ``relative_tolerance``,
            ``gas_amount_hat`` (``n̂``, None under pressure control), ``steps`` (per voltage: ``voltage_kV``,
            ``direction``, the :meth:`state_dict` fields, the segment's ``configuration`` label, with a
            breakdown field ``max_field_MV_per_m``, and any ``note``), ``transitions`` (the transitions, then
            the equal-free-energy voltages, each a :meth:`transition_dict`) and ``notes``.

        Raises
        ------
        SceneError
            If the output would pass the limits of :mod:`coexist.cost` (names the field, suggests ``every``),
            the shapes' numbers included.
        """
        from .cost import ramp_cost

        if self.scene.voltage is not None:
            ramp_cost(self.scene, every).check(every)  # the output must fit before it is built
        steps = []
        check_field = self.scene.breakdown_field is not None
        last = len(self.result.steps) - 1
        previous = None
        kept: list = []  # the state of every kept step (for the shapes)
        for i, s in enumerate(self.result.steps):
            label = s.segment.label if s.segment is not None else "none"
            changed, previous = previous is not None and label != previous, label
            if i % every and not changed and not s.note and i != last:
                continue
            d = {
                # the path's voltage back from Φ̂, to 14 significant digits (rounding 0.020000000000000004 to 0.02): to
                # 10 decimals of a kV it kept 6 digits of a membrane 1000 times softer (0.0006324555 for 0.000632455532)
                "voltage_kV": float(f"{float(self.voltage_kV(s.phi_hat)):.14g}"),
                "direction": s.direction,
                **self.state_dict(s.state),
            }
            if s.segment is not None:
                d["configuration"] = s.segment.label
            if check_field and s.state is not None:
                d["max_field_MV_per_m"] = float(max(s.state.max_field) * self.scene.field_scale / 1e6)
            if s.note:
                d["note"] = s.note
            steps.append(d)
            kept.append(s.state)
        if shapes:
            self._add_shapes(steps, kept, shape_points, every)
        return {
            "scene": self.scene.to_dict(),
            "effects": self.effects,
            "fitted_parameters": self.fitted,
            "relative_tolerance": self.settings.rtol,
            "gas_amount_hat": getattr(self.gas, "gas_amount", None),
            "steps": steps,
            "transitions": [self.transition_dict(t) for t in self.result.transitions + self.result.equal_free_energy],
            "notes": self.result.notes,
        }

    def to_xarray(self, every: int = 1):
        """The report as an :class:`xarray.Dataset` (:func:`coexist.labelled.ramp_dataset`): dimensions ``step``
        (coordinates ``voltage_kV``, ``direction``), ``zone`` and ``transition``, units in the attributes.

        Parameters
        ----------
        every : int, optional
            Keep every ``every``-th voltage, as :meth:`to_dict`.

        Returns
        -------
        xarray.Dataset
        """
        from .labelled import ramp_dataset

        return ramp_dataset(self, every)

    def _add_shapes(self, steps: list, states: list, points: int, every: int) -> None:
        """``shapes`` of every step dict (:meth:`to_dict`): all the states' profiles computed in one batch."""
        from .cost import MAX_OUTPUT_NUMBERS, ramp_cost
        from .shapes import MIN_POINTS, profiles

        if points and (isinstance(points, bool) or not isinstance(points, int) or points < MIN_POINTS):
            raise SceneError(f"must be 0 or an integer of at least {MIN_POINTS}, got {points!r}", "shape_points")
        groups = sum(len(st.pole_stretch) for st in states if st is not None)
        numbers = ramp_cost(self.scene, every).numbers if self.scene.voltage is not None else 0
        numbers += groups * (8 + 2 * points)
        if numbers > MAX_OUTPUT_NUMBERS:
            raise SceneError(
                f"the ramp with its shapes would print {numbers:,} numbers, more than {MAX_OUTPUT_NUMBERS:,}: "
                "print fewer voltages (a larger --every) or fewer profile points",
                "every",
            )
        lam = [x for st in states if st is not None for x in st.pole_stretch]
        phi = [st.phi_hat for st in states if st is not None for _ in st.pole_stretch]
        if not lam:
            found = []
        elif self.scene.patterned:  # region by region, the electrode edges among the points
            from .shapes import patterned_profiles

            found = patterned_profiles(
                self.scene.model(),
                self.scene.zone_pattern(),
                lam,
                phi,
                zone_radius=self.scene.zone_radius,
                points=max(points, MIN_POINTS),
                settings=self.settings,
            )
        else:
            found = profiles(
                self.scene.model(),
                lam,
                phi,
                zone_radius=self.scene.zone_radius,
                points=max(points, MIN_POINTS),
                settings=self.settings,
                wrinkled="numbers",
            )
        profs = iter(found)
        for d, st in zip(steps, states):
            if st is None:
                d["shapes"] = None
                continue
            d["shapes"] = [
                {"zones": int(n), **next(profs).to_dict(points=bool(points))} for n in st.configuration.counts
            ]


def simulate_ramp(scene: Scene, settings: SolverSettings | None = None, progress=None) -> RampReport:
    """Run the scene's voltage path through the whole pipeline (a convenience for ``Simulation``).

    Parameters
    ----------
    scene : Scene
        The experiment; it needs a ``[voltage]`` and a chamber or a controlled pressure.
    settings : SolverSettings, optional
        Default: :class:`SolverSettings`.
    progress : callable, optional
        Called with the index of each voltage of the path once it is done.

    Returns
    -------
    RampReport
        ``Simulation.from_scene(scene, settings).ramp(progress)``.

    Raises
    ------
    SceneError
        As :meth:`Simulation.from_scene` and :meth:`Simulation.ramp`.
    """
    return Simulation.from_scene(scene, settings).ramp(progress)
