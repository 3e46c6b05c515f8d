"""Every numerical choice of the library, in one object passed down to every solver.

The physical scene (:class:`~coexist.scene.Scene`) says what is simulated; :class:`SolverSettings` says
how: the integrator's tolerance and everything derived from it (Newton, bracketing and event
tolerances), the sample counts of every grid, and the continuation's step control. The command line's
``--rtol`` / ``--accuracy`` options set ``rtol``, and through it every tolerance below; the accuracy
study (``coexist accuracy``) reads the sampling defaults from here.
"""

from __future__ import annotations

from dataclasses import dataclass, fields, replace

from .errors import SceneError

#: Named accuracy levels offered by every command (``--accuracy``); values are relative tolerances.
ACCURACY_LEVELS = {"draft": 1e-6, "default": 1e-10, "high": 1e-12}
#: the tightest relative tolerance taken (below it the states' rounding, ~1e-15, is the error)
RTOL_MIN = 1e-14
#: the loosest relative tolerance taken: at 1e-3 and looser the default ramp fails (its jump finds no landing,
#: its Newton iterations no reliable residual); the accuracy study goes up to 1e-4
RTOL_MAX = 1e-4


@dataclass(frozen=True)
class SolverSettings:
    """Tolerances, sample counts and limits of the shooting integrator and the solvers built on it.

    Parameters
    ----------
    rtol : float
        Relative tolerance of the adaptive 8th-order Runge-Kutta (DOP853) integration of the
        membrane equations. The shooting result (``p̂``, ``V̂``, ``Q̂``, ``Ψ̂``) carries a relative
        error of about ``rtol`` (see ``coexist accuracy``); every Newton, bracketing and event tolerance
        of the library is derived from it (the properties below).
    atol_factor : float
        Absolute tolerance as a multiple of ``rtol`` (states are of order one after scaling); at most 1.
    pole_radius : float or None
        Radius ``R0/R*`` at which the series start at the pole hands over to the integrator; the
        series is accurate to ``O(R0^4)``, so at most ``rtol^¼``. ``None`` (default):
        ``R0 = min(1e-3, 0.1 rtol^¼)``, so the truncation stays below the tolerance while the first steps
        are not wasted on the pole.
    max_steps : int
        Largest number of integration steps per trajectory before it is declared failed.
    max_radius_factor : float
        A trajectory that has not returned to the clamp stretch by ``R = max_radius_factor``
        (in units of the estimated clamp radius) has no equilibrium at that pole stretch.
    sensitivity_error_control : bool
        Whether the variational equations (exact derivatives of a state to ``λ0`` and ``Φ̂``) take part
        in the integrator's step-size control. Off (default): they are integrated on the steps the
        states choose, which makes them the exact derivatives of the discrete solution; measured
        against ``rtol = 1e-13``, they then carry the relative error of the states themselves (see
        ``tests/test_sensitivities.py``) at half the cost.
    error_estimates : bool
        Measure the error of every transition voltage by locating it again at ``rtol/100`` (at least
        1e-13); off, a transition carries only its location bracket.
    limit_point_xtol : float
        Relative width in pole stretch at which the search for a pressure or voltage extremum stops
        (it usually stops earlier, when the extremal value has settled to ``rtol/2``).
    limit_point_nodes : int
        Chebyshev nodes per round of that search.
    curve_points : int
        Pole stretches of a ``p̂–V̂`` curve when none are given (:func:`~coexist.curves.pressure_volume_curve`).
    charge_curve_points : int
        Pole stretches of a ``Φ̂–Q̂`` curve when none are given (:func:`~coexist.curves.voltage_charge_curve`).
    zone_curve_points : int
        Points of the zone curves the N-zone layer takes first guesses and figures from
        (:class:`~coexist.zone_curves.ZoneCurve`; never a reported number).
    jump_curve_points : int
        Points of the zone curve a ramp's jump runs its gradient flow on (it decides the basin only; the
        landing state is then solved exactly).
    snap_grid_points : int
        Pole stretches on which the zero-voltage pressure maximum is first bracketed.
    phase_diagram_points : int
        Spline points per voltage of the one-zone phase diagram (:func:`~coexist.coexistence.phase_diagram`).
    maxwell_guess_samples : int
        Pressures sampled for the first guess of the one-zone equal-area construction.
    candidate_samples : int
        Samples per branch on which the first guesses of N-zone equilibria are bracketed.
    stability_samples : int
        Points between the flat state and a zone's stretch on which its curve's folds and pressure
        extrema are counted (the fold index, :func:`~coexist.equilibria.fold_index`).
    fold_refinements : int
        Times an interval where ``|dV̂/du|`` is small is halved while counting folds (a spiral's folds
        crowd together).
    discovery_voltages : int
        Voltages at which every configuration is searched for when the coexistence table is asked for.
    fit_samples : int
        A fit tries at most ``6·fit_samples`` zone radii to bracket its root (:func:`~coexist.fit.fit_zone_radius`).
    locking_margin : float
        The pole-stretch range of the zone curves ends at this fraction of the Gent locking stretch.
    stretch_max_factor : float
        ... and for materials that do not lock, at this multiple of the prestretch.
    initial_step, max_step, min_step : float
        First, largest and smallest arclength step of the continuation (scaled coordinates ``z``).
    max_turn : float
        Largest angle (radians) between the tangents of two accepted continuation points.
    max_newton : int
        Newton iterations per continuation corrector.
    max_points : int
        Accepted points per branch before the continuation stops (a safeguard; the notes say so).
    loose_tolerance : float
        Newton step below which a point *along* a branch is accepted (it only serves as the next predictor
        and to bracket events; every reported state and every located event is converged to
        :attr:`newton_tol`).
    chord_below : float
        Once a Newton step is this small, the next evaluation reuses the last Jacobian (a chord step).
    merge_tolerance : float
        Below this separation in ``u`` two groups of zones count as one state.
    """

    # integration
    rtol: float = 1e-10
    atol_factor: float = 1e-2
    pole_radius: float | None = None
    max_steps: int = 4000
    max_radius_factor: float = 1000.0
    sensitivity_error_control: bool = False
    error_estimates: bool = True
    # limit points
    limit_point_xtol: float = 1e-9
    limit_point_nodes: int = 9
    # sampling
    curve_points: int = 200
    charge_curve_points: int = 120
    zone_curve_points: int = 240
    jump_curve_points: int = 160
    snap_grid_points: int = 80
    phase_diagram_points: int = 128
    maxwell_guess_samples: int = 200
    candidate_samples: int = 400
    stability_samples: int = 64
    fold_refinements: int = 4
    discovery_voltages: int = 13
    fit_samples: int = 12
    locking_margin: float = 0.95
    stretch_max_factor: float = 6.0
    # continuation
    initial_step: float = 0.05
    max_step: float = 0.6
    min_step: float = 1e-7
    max_turn: float = 0.35
    max_newton: int = 12
    max_points: int = 600
    loose_tolerance: float = 1e-6
    chord_below: float = 1e-4
    merge_tolerance: float = 1e-7

    def __post_init__(self):
        from . import validation

        for f in fields(self):  # types first: every field a finite number of its kind (or a bool / None)
            value = getattr(self, f.name)
            if f.name == "pole_radius" and value is None:
                continue
            if isinstance(f.default, bool):
                if not isinstance(value, bool):
                    raise SceneError(f"{f.name} must be True or False, got {value!r}", f.name)
            elif isinstance(f.default, int):  # a numpy integer is taken as the int it is
                object.__setattr__(self, f.name, validation.integer(value, f.name, lo=1))
            else:
                object.__setattr__(self, f.name, validation.real(value, f.name, lo=0.0, lo_open=True))
        if not (RTOL_MIN <= self.rtol <= RTOL_MAX):
            raise SceneError(
                f"relative tolerance must lie in [1e-14, 1e-4], got {self.rtol!r}"
                + (
                    " (looser tolerances leave the ramp's Newton iterations without a reliable residual)"
                    if self.rtol > RTOL_MAX
                    else ""
                ),
                "rtol",
            )
        if self.max_steps < 10:
            raise SceneError(f"max_steps must be at least 10, got {self.max_steps!r}", "max_steps")
        for f in fields(self):
            value = getattr(self, f.name)
            if f.name.endswith(("_points", "_samples", "_voltages", "_nodes")) and not (
                isinstance(value, int) and value >= 5
            ):
                raise SceneError(f"{f.name} must be an integer of at least 5, got {value!r}", f.name)
        if self.pole_radius is not None and self.pole_radius > self.rtol**0.25:
            # the series start is accurate to O(R0^4): beyond rtol^(1/4) it is wrong by more than rtol, and the
            # states are still marked OK (a 6 % error at 0.5: review, helper-62)
            raise SceneError(
                f"pole_radius must be at most rtol^(1/4) = {self.rtol**0.25:.3g} (the pole series is accurate to "
                f"O(R0^4)), got {self.pole_radius!r}",
                "pole_radius",
            )
        if self.atol_factor > 1:
            raise SceneError(
                f"atol_factor must be at most 1 (the absolute tolerance atol_factor·rtol of states of order one "
                f"may not exceed the relative one), got {self.atol_factor!r}",
                "atol_factor",
            )
        if not (0 < self.locking_margin < 1):
            raise SceneError(f"locking_margin must lie in (0, 1), got {self.locking_margin!r}", "locking_margin")
        if not (0 < self.min_step <= self.initial_step <= self.max_step):
            raise SceneError("continuation steps must satisfy 0 < min_step <= initial_step <= max_step", "min_step")

    @property
    def series_radius(self) -> float:
        """The pole radius in use (see ``pole_radius``)."""
        if self.pole_radius is not None:
            return float(self.pole_radius)
        return min(1e-3, 0.1 * self.rtol**0.25)

    @property
    def atol(self) -> float:
        """Absolute tolerance ``atol_factor * rtol``."""
        return self.atol_factor * self.rtol

    @property
    def newton_tol(self) -> float:
        """Newton step (in ``u``) below which a corrector has converged: ``max(rtol, 1e-14)``, the
        shooting's own precision (a step is amplified into the residual by ``dp̂/du``, a few units; where the
        shooting's noise keeps the steps from shrinking, the corrector stops there instead)."""
        return max(self.rtol, 1e-14)

    @property
    def event_tol(self) -> float:
        """Bracket width (arclength) at which an event along a branch counts as located: ``10 newton_tol``."""
        return 10 * self.newton_tol

    @property
    def residual_tol(self) -> float:
        """Relative residual of an equilibrium's pressure balance that counts as converged: ``10 rtol``."""
        return 10 * self.rtol

    def crossing_tol(self, phi_hat: float) -> float:
        """Newton step in ``Φ̂`` at which an equal-free-energy voltage has converged: ``100 rtol max(|Φ̂|, 1e-3)``
        (the free energies carry ``rtol``, their difference is divided by the difference of charges).

        Parameters
        ----------
        phi_hat : float
            The voltage ``Φ̂`` being solved for.

        Returns
        -------
        float
            The step tolerance in ``Φ̂``.
        """
        return 100 * self.rtol * max(abs(phi_hat), 1e-3)

    @property
    def inner_ftol(self) -> float:
        """Relative residual to which an inner root (a voltage at a pressure) is solved: ``rtol/1000``,
        well inside the states' own precision, so that it adds nothing to the error of what it feeds."""
        return 1e-3 * self.rtol

    def with_rtol(self, rtol: float) -> SolverSettings:
        """A copy with another relative tolerance (every derived tolerance follows it).

        Parameters
        ----------
        rtol : float
            The new relative tolerance, in ``[RTOL_MIN, RTOL_MAX] = [1e-14, 1e-4]``.

        Returns
        -------
        SolverSettings
            The copy; every other field unchanged, but an explicit ``pole_radius`` above ``rtol^¼`` (allowed at
            the old tolerance) lowered to it.

        Raises
        ------
        SceneError
            If ``rtol`` lies outside ``[RTOL_MIN, RTOL_MAX] = [1e-14, 1e-4]``.
        """
        radius = self.pole_radius
        if radius is not None and isinstance(rtol, (int, float)) and not isinstance(rtol, bool) and rtol > 0:
            # a radius allowed at this rtol may not be at a tighter one (an event located again at rtol/100 raised
            # on a user's pole_radius = 1e-3 at rtol 1e-11: review, helper-63); the series needs it no larger
            radius = min(radius, rtol**0.25)
        return replace(self, rtol=rtol, pole_radius=radius)  # __post_init__ checks rtol (a number, in range)

    @classmethod
    def from_accuracy(cls, accuracy: str | float | None) -> SolverSettings:
        """Settings for a named accuracy level (``draft``, ``default``, ``high``) or a tolerance.

        Parameters
        ----------
        accuracy : str or float or None
            A level of :data:`ACCURACY_LEVELS` (case and surrounding blanks ignored), a relative tolerance
            (a number or its text, e.g. ``"1e-8"``), or ``None`` for the defaults.

        Returns
        -------
        SolverSettings
            Default settings with ``rtol`` set accordingly.

        Raises
        ------
        SceneError
            If the text is neither a level nor a tolerance in ``[1e-14, 1e-4]`` (field ``accuracy``), or a
            number lies outside ``[RTOL_MIN, RTOL_MAX] = [1e-14, 1e-4]`` (field ``rtol``).

        Examples
        --------
        >>> SolverSettings.from_accuracy("high").rtol
        1e-12
        >>> SolverSettings.from_accuracy("1e-8").newton_tol
        1e-08
        """
        if accuracy is None:
            return cls()
        if isinstance(accuracy, str):
            key = accuracy.strip().lower()
            if key in ACCURACY_LEVELS:
                return cls(rtol=ACCURACY_LEVELS[key])
            try:
                rtol = float(key)
            except ValueError:
                names = ", ".join(ACCURACY_LEVELS)
                raise SceneError(
                    f"unknown accuracy {accuracy!r}; use one of {names} or a tolerance like 1e-8",
                    "accuracy",
                ) from None
            return cls(rtol=rtol)
        return cls(rtol=accuracy)  # __post_init__ checks it (a number, in range)


def tight_settings(settings: SolverSettings) -> SolverSettings:
    """The settings an error is measured with: ``rtol/100``, at least 1e-13 (as a transition voltage's), and the
    pole series handed over at a radius smaller by the fourth root of the same factor (its truncation is
    ``O(R0⁴)``), so that it too is measured: the default radius stops growing at 1e-3 for ``rtol ≥ 1e-8``, and at
    rtol 1e-6 both runs shared it (a flat pressure minimum's location, 9e-5 off in λ0 with ``R0 = 1e-3``, was given
    ± 3.5e-6: review, helper-64).

    Parameters
    ----------
    settings : SolverSettings
        The settings of the run.

    Returns
    -------
    SolverSettings
        ``settings`` with ``rtol' = max(rtol/100, 1e-13)`` and ``pole_radius = R0 min(1, rtol'/rtol)^¼`` (``R0``
        the radius in use, :attr:`SolverSettings.series_radius`; at most ``rtol'^¼``).
    """
    rtol = max(settings.rtol / 100, 1e-13)
    # never larger (at rtol < 1e-13 the "tighter" tolerance is 1e-13), and never above rtol'^¼ by a rounding (a
    # radius at the largest allowed, rtol^¼, raised: review, helper-65)
    radius = min(settings.series_radius * min(1.0, rtol / settings.rtol) ** 0.25, rtol**0.25)
    return replace(settings.with_rtol(rtol), pole_radius=radius)


def measured_error(value: float, tight_value: float, rtol: float) -> float:
    """The error given to a number solved at ``rtol`` and again at ``rtol/100``: ``2 |value − tight| + rtol |value|``
    (twice the change, as the tighter value carries noise of its own; never below the relative tolerance the
    states themselves carry).

    Parameters
    ----------
    value, tight_value : float
        The number at the run's tolerance and at the tighter one.
    rtol : float
        The run's relative tolerance.

    Returns
    -------
    float
        The error estimate.
    """
    return float(2 * abs(value - tight_value) + rtol * abs(value))


def error_reference(settings: SolverSettings) -> SolverSettings:
    """The settings a limit point's error is measured against: :func:`tight_settings` where they are tighter than
    ``settings``; at ``rtol ≤ 1e-13``, where they are not (a second run at the same tolerance only repeats the
    first), ``100 rtol``: the change is then mostly the looser run's own error, an overestimate of this one's.

    Parameters
    ----------
    settings : SolverSettings
        The settings of the run.

    Returns
    -------
    SolverSettings
        ``settings`` with ``rtol = rtol/100`` (at least 1e-13), or ``100 rtol`` when that is not tighter.
    """
    tight = tight_settings(settings)
    return tight if tight.rtol < settings.rtol else settings.with_rtol(min(100 * settings.rtol, RTOL_MAX))
