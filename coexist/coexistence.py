"""Equal free energy: coexisting bulged and unbulged zones, solved with CasADi.

Two zones at the same pressure ``p̂`` and voltage ``Φ̂`` coexist when they sit on two stable
branches of the same curve with equal potential (the Maxwell condition, docs/physics.md)::

    p̂(u_b) = p̂(u_u),      Ψ̂(u_b) − Ψ̂(u_u) = p̂ (V̂(u_b) − V̂(u_u))

i.e. equal areas on the ``p̂–V̂`` curve at fixed ``Φ̂``. The same two states satisfy the equal-area
rule on the ``Φ̂–Q̂`` curve at fixed ``p̂`` (the potential at fixed ``p`` and ``Φ``, ``Ψ − pV``, is
equal in both), so one solver serves both readings.

The curve is the cubic spline of :class:`~coexist.zone_curves.ZoneCurve`, rebuilt piece by piece as
a CasADi expression so that the Newton solve has exact derivatives of exactly the function the
rest of the project uses; its own error against shooting is measured by the curve
(``interpolation_error``). A solution with the two states merged (the trivial one) is never
returned: near the critical point where the two stable branches merge, :class:`ModelRangeError`
says that coexistence ends there (:func:`phase_diagram` says on which side of the critical point the loop is).

The spline solution is only a first guess for a reported number (the splines are accurate to about
1e-6): :func:`exact_coexistence` solves the same two equations again by Newton on exactly shot states
(exact derivatives from the variational equations, ``∂Ψ̂/∂λ0 = p̂ ∂V̂/∂λ0``) and measures the error of
``p̂`` by solving once more at ``rtol/100``; :func:`phase_diagram` reports only such solutions, and its
spinodals are limit points located on exact states (as :func:`~coexist.curves.pressure_volume_curve`
locates them), their errors measured the same way.
"""

from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

from .errors import ModelRangeError, SceneError, SolverError
from .numerics.roots import bisect, bracketed_root, chebyshev_extremum
from .numerics.splines import casadi_piecewise
from .settings import SolverSettings, measured_error, tight_settings
from .shooting import StateDerivatives, solve_states
from .validation import instance, membrane_model, real, real_array, settings_or_default
from .zone_curves import ZoneCurve

#: iterations allowed to every CasADi Newton solve
MAX_NEWTON_ITERATIONS = 60
#: absolute roundoff of the spline equations (values of order one, a few dozen operations)
ROUNDOFF = 1e-13
#: width in Φ̂ to which a change between loop and no loop is bisected on the curves, and to which the critical
#: point (where the pressure maximum and minimum merge) is then solved on the exact equations
CRITICAL_XTOL = 1e-8
#: Newton iterations allowed to the solve of a coexisting pair on exact states (from the spline solution it
#: takes two or three)
EXACT_NEWTON_ITERATIONS = 20


@dataclass
class Coexistence:
    """Coexisting unbulged (``u``) and bulged (``b``) states of one zone at voltage ``phi_hat``.

    Attributes
    ----------
    phi_hat, p_hat : float
        The voltage ``Φ̂`` and the common pressure ``p̂``.
    pole_stretch_unbulged, pole_stretch_bulged : float
        Pole stretches ``λ0`` of the two states.
    v_unbulged, v_bulged, q_unbulged, q_bulged, psi_unbulged, psi_bulged : float
        ``V̂``, ``Q̂`` and ``Ψ̂`` of the two states (from the curve's splines; from the exact states when
        ``exact``).
    residual : float
        Largest residual of the equal-area equations at the solution (of the spline equations; of the exact
        equations on the shot states when ``exact``).
    iterations : int
        Newton iterations taken (-1 if CasADi does not report them).
    exact : bool
        Whether the pair is solved on exactly shot states (:func:`exact_coexistence`), not on the splines.
    p_hat_error : float or None
        The error of ``p_hat``, measured by solving again at ``rtol/100`` (:func:`measured_error`); None
        for a spline solution (whose error is that of the splines, about 1e-6).
    """

    phi_hat: float
    p_hat: float
    pole_stretch_unbulged: float
    pole_stretch_bulged: float
    v_unbulged: float
    v_bulged: float
    q_unbulged: float
    q_bulged: float
    psi_unbulged: float
    psi_bulged: float
    residual: float
    iterations: int
    exact: bool = False
    p_hat_error: float | None = None

    def to_dict(self) -> dict:
        """JSON-ready dict of the fields.

        Returns
        -------
        dict
            Every field by name (``phi_hat``, ``p_hat``, ``pole_stretch_unbulged``, ...).
        """
        return dict(self.__dict__)


class MaxwellSolver:
    """Builds the CasADi equal-free-energy system for one :class:`ZoneCurve` and solves it.

    Parameters
    ----------
    curve : ZoneCurve
        The zone's curve at one voltage.
    settings : SolverSettings, optional
        Tolerances and ``maxwell_guess_samples``; default ``SolverSettings()``.
    """

    #: spline pieces kept on each side of the initial guess
    WINDOW = 6

    def __init__(self, curve: ZoneCurve, settings: SolverSettings | None = None):
        self.curve = curve
        self.settings = settings or SolverSettings()

    def _build(self, guess):
        """The cached CasADi residual and Newton rootfinder, and their parameters: the spline pieces of
        ``p̂``, ``V̂``, ``Ψ̂`` in a window of ``2 WINDOW + 1`` pieces around each state of ``guess``."""
        c = self.curve
        pieces = c.grid.size - 1
        K = min(2 * self.WINDOW + 1, pieces)
        params, bounds = [], []
        for g in guess:
            i = int(np.clip(np.searchsorted(c.grid, g) - 1, 0, pieces - 1))
            s0 = int(np.clip(i - self.WINDOW, 0, pieces - K))
            params.append(c.grid[s0 : s0 + K + 1])
            params.extend(spline.c[:, s0 : s0 + K].ravel(order="F") for spline in (c.p, c.v, c.psi))
            bounds.append((c.grid[s0], c.grid[s0 + K]))
        residual, rootfinder = _maxwell_functions(K, max(self.settings.inner_ftol, ROUNDOFF))
        return residual, rootfinder, np.concatenate(params), bounds

    def equal_area(self, P: float) -> float | None:
        """Signed area ``Ψ̂(u_b) − Ψ̂(u_u) − P(V̂(u_b) − V̂(u_u))`` at pressure ``P`` between the first
        stable branch and the next stable branch; None where ``P`` is outside either.

        Parameters
        ----------
        P : float
            Normalised pressure ``p̂``.

        Returns
        -------
        float or None
            The signed area; zero at the Maxwell pressure.

        Raises
        ------
        ModelRangeError
            If the curve has fewer than two stable branches (reason ``no_coexistence``).
        """
        a, b = self._stable_pair()
        c = self.curve
        try:
            uu, ub = c.stretch_at_pressure(a, P), c.stretch_at_pressure(b, P)
        except ValueError:
            return None
        return float(c.psi(ub) - c.psi(uu) - P * (c.v(ub) - c.v(uu)))

    def _stable_pair(self):
        rising = [b for b in self.curve.branches if b.rising and b.usable]
        if len(rising) < 2:
            why = f"; {self.curve.stopped_because}" if self.curve.stopped_because else ""
            end = float(np.max(self.curve.pole_stretch))
            raise ModelRangeError(
                f"no coexistence at Φ̂ = {self.curve.phi_hat:.6g}: the curve has no second stable branch up to "
                f"λ0 = {end:.4g}, the end of the range computed{why} (past its pressure minimum it rises again too "
                "little there, or not at all)",
                "no_coexistence",
            )
        return rising[0], rising[1]

    def initial_guess(self):
        """Bracket the Maxwell pressure on the overlap of the two stable branches (sign change of the area
        on ``settings.maxwell_guess_samples`` pressures).

        Returns
        -------
        tuple of float
            ``(u_u, u_b)`` on the two stable branches at the middle of the first bracket.

        Raises
        ------
        ModelRangeError
            No second stable branch or no shared pressure (reason ``no_coexistence``), no sign change
            of the area (``no_coexistence``), or a loop too small to resolve (``critical_point``).
        """
        samples = self.settings.maxwell_guess_samples
        a, b = self._stable_pair()
        lo, hi = max(a.p_range[0], b.p_range[0]), min(a.p_range[1], b.p_range[1])
        if not hi > lo:
            raise ModelRangeError(
                f"no coexistence at Φ̂ = {self.curve.phi_hat:.6g}: the two stable branches share no pressure",
                "no_coexistence",
            )
        P = np.linspace(lo, hi, samples)[1:-1]
        c = self.curve
        uu, ub = c.stretch_at_pressure(a, P), c.stretch_at_pressure(b, P)
        area = c.psi(ub) - c.psi(uu) - P * (c.v(ub) - c.v(uu))
        sign = np.flatnonzero(area[:-1] * area[1:] < 0)
        if sign.size == 0:
            loop = abs(c.p(a.stop) - c.p(b.start)) / max(abs(float(c.p(a.stop))), 1e-300)
            if b.start == a.stop or loop < 1e-4 or np.max(np.abs(area)) < 1e-7 * max(1.0, abs(float(c.psi(b.stop)))):
                raise ModelRangeError(
                    f"coexistence ends near Φ̂ = {c.phi_hat:.6g}: so close to the critical point that the "
                    f"equal-area condition is below the curve's resolution (pressure loop {loop:.1e})",
                    "critical_point",
                )
            raise ModelRangeError(
                f"no coexistence at Φ̂ = {c.phi_hat:.6g}: the equal-area pressure lies outside the stable branches",
                "no_coexistence",
            )
        P0 = 0.5 * (P[sign[0]] + P[sign[0] + 1])
        return self.curve.stretch_at_pressure(a, P0), self.curve.stretch_at_pressure(b, P0)

    def solve(self) -> Coexistence:
        """The coexisting pair (CasADi Newton on the exact spline), verified before it is returned.

        Returns
        -------
        Coexistence
            The two states at ``p̂(u_u) = p̂(u_b)`` with equal areas.

        Raises
        ------
        ModelRangeError
            As :meth:`initial_guess`; or the two states merge (reason ``critical_point``).
        SolverError
            Newton does not converge to ``residual_tol``, leaves the spline pieces around its guess or
            the curve, or converges onto a branch with ``dp̂/du ≤ 0``.
        """
        guess = self.initial_guess()
        residual, rootfinder, params, bounds = self._build(guess)
        x = np.array(rootfinder(ca.DM(guess), params)).ravel()
        stats = rootfinder.stats()
        res = float(np.max(np.abs(np.array(residual(x, params)).ravel())))
        c = self.curve
        if not all(lo <= xi <= hi for xi, (lo, hi) in zip(x, bounds)):
            raise SolverError(
                f"equal-free-energy solve at Φ̂ = {c.phi_hat:.6g} left the spline pieces around its initial guess"
            )
        if not (
            stats.get("success", False)
            and np.all(np.isfinite(x))
            and res < max(self.settings.residual_tol, 1e3 * ROUNDOFF)
        ):
            raise SolverError(
                f"equal-free-energy solve failed at Φ̂ = {c.phi_hat:.6g}: "
                f"{stats.get('return_status', 'no convergence')} (residual {res:.2e})"
            )
        uu, ub = x
        lo, hi = c.grid[0], c.grid[-1]
        if not (lo <= uu <= hi and lo <= ub <= hi):
            raise SolverError(f"equal-free-energy solve left the curve at Φ̂ = {c.phi_hat:.6g}")
        if abs(ub - uu) <= 1e-6 * max(1.0, abs(ub)):
            raise ModelRangeError(
                f"coexistence ends at Φ̂ = {c.phi_hat:.6g}: the bulged and unbulged states merge (critical point)",
                "critical_point",
            )
        if c.dp(uu) <= 0 or c.dp(ub) <= 0:
            raise SolverError(f"equal-free-energy solve converged onto an unstable branch at Φ̂ = {c.phi_hat:.6g}")
        return Coexistence(
            phi_hat=c.phi_hat,
            p_hat=float(c.p(uu)),
            pole_stretch_unbulged=float(c.to_stretch(uu)),
            pole_stretch_bulged=float(c.to_stretch(ub)),
            v_unbulged=float(c.v(uu)),
            v_bulged=float(c.v(ub)),
            q_unbulged=float(c.q(uu)),
            q_bulged=float(c.q(ub)),
            psi_unbulged=float(c.psi(uu)),
            psi_bulged=float(c.psi(ub)),
            residual=res,
            iterations=int(stats.get("iter_count", -1)),
        )


_MAXWELL_FUNCTIONS: dict = {}


def _maxwell_functions(K: int, abstol: float):
    """Residual and Newton rootfinder of the equal-area system for two states on windows of ``K`` spline
    pieces, with the pieces as parameters: built once per ``(K, abstol)`` in a process, reused for
    every curve (building them took 23 of 28 ms of a solve).

    Unknowns ``(u_u, u_b)``; residual
    ``[p̂(u_b) − p̂(u_u), Ψ̂(u_b) − Ψ̂(u_u) − ½(p̂(u_u) + p̂(u_b))(V̂(u_b) − V̂(u_u))]``
    (equal pressure; equal potential ``Ψ̂ − p̂V̂`` with the mean pressure, symmetric in the two states).
    """
    key = (K, abstol)
    if key not in _MAXWELL_FUNCTIONS:
        params = []

        def state(x, tag):
            breaks = ca.SX.sym(f"breaks_{tag}", K + 1)
            coefs = [ca.SX.sym(f"{q}_{tag}", 4, K) for q in ("p", "v", "psi")]
            params.extend([breaks, *(ca.vec(c) for c in coefs)])
            return [casadi_piecewise(x, breaks, c) for c in coefs]

        uu, ub = ca.SX.sym("u_unbulged"), ca.SX.sym("u_bulged")
        p_u, v_u, psi_u = state(uu, "unbulged")
        p_b, v_b, psi_b = state(ub, "bulged")
        g = ca.vertcat(p_b - p_u, (psi_b - psi_u) - 0.5 * (p_u + p_b) * (v_b - v_u))
        residual = ca.Function("maxwell_residual", [ca.vertcat(uu, ub), ca.vertcat(*params)], [g])
        options = {"max_iter": MAX_NEWTON_ITERATIONS, "abstol": abstol, "error_on_fail": False}
        _MAXWELL_FUNCTIONS[key] = (residual, ca.rootfinder("maxwell", "newton", residual, options))
    return _MAXWELL_FUNCTIONS[key]


def maxwell_coexistence(curve: ZoneCurve, settings: SolverSettings | None = None, model=None) -> Coexistence:
    """Coexisting unbulged and bulged states of one zone curve at fixed voltage (equal areas).

    Parameters
    ----------
    curve : ZoneCurve
        The zone's ``p̂–V̂`` curve at one voltage, with two stable (rising) branches.
    settings : SolverSettings, optional
        Tolerances (the spline equations are solved to ``inner_ftol``, verified to ``residual_tol``).
    model : MembraneModel, optional
        The model the curve was shot with. Given, the spline solution is only the first guess of
        :func:`exact_coexistence`, which returns the pair converged on exact states with its measured error;
        without it the result is the spline solution (accurate to the splines, about 1e-6).

    Returns
    -------
    Coexistence
        ``p̂`` with ``p̂(u_u) = p̂(u_b)`` and ``Ψ̂(u_b) − Ψ̂(u_u) = p̂ (V̂(u_b) − V̂(u_u))`` (equal areas).

    Raises
    ------
    ModelRangeError
        No second stable branch, or too close to the critical point to resolve.
    SolverError
        The Newton solve failed (says why).
    """
    instance(curve, ZoneCurve, "curve", "a ZoneCurve (ZoneCurve.compute(model, phi_hat, pole_stretch))")
    settings = settings_or_default(settings)
    guess = MaxwellSolver(curve, settings).solve()
    if model is None:
        return guess
    membrane_model(model)
    return exact_coexistence(model, guess, settings)


def _exact_pair(model, phi_hat: float, guess, settings: SolverSettings):
    """Newton on exactly shot states for the pole stretches ``(λu, λb)`` of a coexisting pair at ``phi_hat``::

        F1 = p̂b − p̂u = 0,      F2 = Ψ̂b − Ψ̂u − ½(p̂u + p̂b)(V̂b − V̂u) = 0

    with the exact Jacobian (``∂Ψ̂/∂λ0 = p̂ ∂V̂/∂λ0``, so with ``ΔV̂ = V̂b − V̂u``)::

        ∂F1/∂λu = −p̂u',   ∂F1/∂λb = p̂b',
        ∂F2/∂λu = ½(p̂b − p̂u)V̂u' − ½p̂u'ΔV̂,   ∂F2/∂λb = ½(p̂b − p̂u)V̂b' − ½p̂b'ΔV̂

    (primes: ``∂/∂λ0`` at fixed ``Φ̂``; its determinant at a solution is ``p̂u' p̂b' ΔV̂``, nonzero away from
    the critical point). Converged when the residuals relative to ``p̂`` and ``p̂ΔV̂`` are below
    ``inner_ftol`` or, once below ``residual_tol``, stop falling tenfold per step (the states' own noise).
    Returns ``(states, residual, iterations)``, ``residual`` the larger absolute residual; raises SolverError."""
    lam = np.array(guess, dtype=float)
    pre = model.prestretch
    best, previous = None, np.inf
    for it in range(EXACT_NEWTON_ITERATIONS + 1):
        s = solve_states(model, lam, phi_hat, settings, derivatives=True)
        if not np.all(s.ok):
            raise SolverError(
                f"equal-free-energy solve on exact states at Φ̂ = {phi_hat:.6g}: no valid state at "
                f"λ0 = {lam[~s.ok][0]:.10g}"
            )
        d = StateDerivatives.of(s)
        (pu, pb), (vu, vb), (qu, qb) = s.p_hat, s.v_hat, s.psi_hat
        dv, pm = vb - vu, 0.5 * (pu + pb)
        F = np.array([pb - pu, (qb - qu) - pm * dv])
        scaled = float(np.max(np.abs(F) / np.array([abs(pm), abs(pm * dv)])))
        if best is None or scaled < best[1]:
            best = (s, scaled, float(np.max(np.abs(F))), it)
        if scaled <= settings.inner_ftol or (scaled <= settings.residual_tol and scaled > 0.1 * previous):
            break
        previous = scaled
        (dpu, dpb), (dvu, dvb) = d.dp_dl0, d.dv_dl0
        J = np.array([[-dpu, dpb], [0.5 * (pb - pu) * dvu - 0.5 * dpu * dv, 0.5 * (pb - pu) * dvb - 0.5 * dpb * dv]])
        try:
            step = np.linalg.solve(J, -F)
        except np.linalg.LinAlgError:
            raise SolverError(
                f"equal-free-energy solve on exact states at Φ̂ = {phi_hat:.6g}: singular Jacobian "
                "(the two states merge: critical point)"
            ) from None
        lam = lam + step
        if not (np.all(np.isfinite(lam)) and pre < lam[0] < lam[1]):
            raise SolverError(
                f"equal-free-energy solve on exact states at Φ̂ = {phi_hat:.6g} left the physical range "
                f"(λ0 = {lam[0]:.6g}, {lam[1]:.6g})"
            )
    if best is None:  # the loop runs at least once
        raise SolverError(f"equal-free-energy solve on exact states at Φ̂ = {phi_hat:.6g}: no iteration")
    s, scaled, residual, it = best
    if not scaled <= settings.residual_tol:
        raise SolverError(
            f"equal-free-energy solve on exact states at Φ̂ = {phi_hat:.6g} did not converge in "
            f"{EXACT_NEWTON_ITERATIONS} Newton steps (relative residual {scaled:.1e}, "
            f"needs {settings.residual_tol:.0e})"
        )
    d = StateDerivatives.of(s)
    if np.any(d.dp_dl0 <= 0) or np.any(d.dv_dl0 <= 0):
        raise SolverError(
            f"equal-free-energy solve on exact states converged onto an unstable branch at Φ̂ = {phi_hat:.6g}"
        )
    return s, residual, it


def exact_coexistence(model, guess: Coexistence, settings: SolverSettings | None = None) -> Coexistence:
    """The coexisting pair of ``guess`` (e.g. the spline solution) converged on the exact equations.

    At fixed ``Φ̂`` the pole stretches ``(λu, λb)`` solve, on states shot exactly at them,

        p̂(λu) = p̂(λb) = p̂b,      Ψ̂(λb) − p̂b V̂(λb) = Ψ̂(λu) − p̂b V̂(λu)

    (equal pressure, equal potential ``Ψ̂ − p̂V̂`` at fixed ``p`` and ``Φ``: the Maxwell equal-area rule), by
    Newton with exact derivatives (:func:`_exact_pair`). The same solve is repeated from the solution at
    ``rtol/100`` (at least 1e-13); the error of ``p̂b`` is :func:`measured_error` of the two.

    Parameters
    ----------
    model : MembraneModel
        The membrane (with its pattern, if any).
    guess : Coexistence
        A first guess at the same voltage (its pole stretches are used).
    settings : SolverSettings, optional
        Tolerances; default ``SolverSettings()``.

    Returns
    -------
    Coexistence
        ``exact = True``; ``p_hat`` is the mean of the two states' pressures, every field from the shot
        states, ``residual`` the larger absolute residual of the two equations there, ``p_hat_error`` the
        measured error.

    Raises
    ------
    SolverError
        If Newton does not converge (or the states fail) at either tolerance, or converges onto a branch with
        ``∂p̂/∂λ0 ≤ 0`` or ``∂V̂/∂λ0 ≤ 0``.
    """
    settings = settings_or_default(settings)
    membrane_model(model)
    instance(guess, Coexistence, "guess", "a Coexistence (maxwell_coexistence(curve))")
    phi = guess.phi_hat
    s, residual, it = _exact_pair(model, phi, (guess.pole_stretch_unbulged, guess.pole_stretch_bulged), settings)
    tight, _, _ = _exact_pair(model, phi, s.pole_stretch, tight_settings(settings))
    p = float(np.mean(s.p_hat))
    return Coexistence(
        phi_hat=float(phi),
        p_hat=p,
        pole_stretch_unbulged=float(s.pole_stretch[0]),
        pole_stretch_bulged=float(s.pole_stretch[1]),
        v_unbulged=float(s.v_hat[0]),
        v_bulged=float(s.v_hat[1]),
        q_unbulged=float(s.q_hat[0]),
        q_bulged=float(s.q_hat[1]),
        psi_unbulged=float(s.psi_hat[0]),
        psi_bulged=float(s.psi_hat[1]),
        residual=residual,
        iterations=it,
        exact=True,
        p_hat_error=measured_error(p, float(np.mean(tight.p_hat)), settings.rtol),
    )


@dataclass
class PhaseDiagram:
    """The ``(Φ̂, p̂)`` plane of one zone: spinodals, binodal and the critical point.

    ``spinodal_max``/``spinodal_min`` hold ``(Φ̂, p̂)`` of the pressure maximum and the following
    minimum of the curve (the limits of stability under pressure control): the maximum wherever the unbulged branch
    has one (its snap-through), the minimum only where a stable branch rises beyond it (a minimum past a volume
    fold, on the inward spiral of the ``p̂–V̂`` curve, is none); ``binodal`` the
    Maxwell coexistence pressure; ``critical_point`` the ``(Φ̂, p̂, λ0)`` where the maximum and
    minimum truly merge (None if they merge nowhere in the range, e.g. where the minimum only crosses
    the end of the pole-stretch range searched); ``notes`` where and why lines end.

    Every pressure is converged on the exact equations (the spinodals exact limit points of ``p̂(λ0)``,
    the binodal :func:`exact_coexistence`); ``spinodal_max_error``, ``spinodal_min_error`` and
    ``binodal_error`` are their errors, measured by solving again at ``rtol/100`` (:func:`measured_error`;
    NaN where the pressure is NaN).
    """

    phi_hat: np.ndarray
    spinodal_max: np.ndarray
    spinodal_min: np.ndarray
    binodal: np.ndarray
    coexistence: list
    critical_point: tuple | None
    notes: list
    spinodal_max_error: np.ndarray | None = None
    spinodal_min_error: np.ndarray | None = None
    binodal_error: np.ndarray | None = None

    def to_dict(self) -> dict:
        """JSON-ready dict (NaN as None).

        Returns
        -------
        dict
            ``phi_hat``, ``spinodal_max_p_hat``, ``spinodal_min_p_hat``, ``binodal_p_hat`` and their
            ``..._error`` (lists; the error lists only when set), ``coexisting_states`` (their
            :meth:`Coexistence.to_dict`), ``critical_point`` (a dict of ``phi_hat``, ``p_hat``,
            ``pole_stretch``, or None) and ``notes``.
        """

        def clean(a):
            return [None if not np.isfinite(x) else float(x) for x in a]

        errors = {
            f"{name}_p_hat_error": clean(e)
            for name, e in (
                ("spinodal_max", self.spinodal_max_error),
                ("spinodal_min", self.spinodal_min_error),
                ("binodal", self.binodal_error),
            )
            if e is not None
        }
        return {
            "phi_hat": clean(self.phi_hat),
            "spinodal_max_p_hat": clean(self.spinodal_max),
            "spinodal_min_p_hat": clean(self.spinodal_min),
            "binodal_p_hat": clean(self.binodal),
            **errors,
            "coexisting_states": [c.to_dict() for c in self.coexistence],
            "critical_point": (
                None
                if self.critical_point is None
                else dict(zip(("phi_hat", "p_hat", "pole_stretch"), map(float, self.critical_point)))
            ),
            "notes": self.notes,
        }


def _loop(curve: ZoneCurve):
    """The pressure maximum of the unbulged branch (:func:`_snap_maximum`) and the first minimum beyond it whose states
    rise in volume and are stable at their volume (:func:`~coexist.equilibria.zone_index_on_curve` 0), as ``u``
    values, or None: the two limits of stability under pressure control, between the stable branch below the
    maximum and the one beyond the minimum.

    A minimum of ``p̂(λ0)`` past a volume fold is no such limit (an inward spiral of the ``p̂–V̂`` curve: Gent 97 from
    ``Φ̂ = 0.26``, where the states beyond it have two unstable modes under pressure control; it was reported as a
    spinodal; review, helper-82), and the extrema of such a spiral between the maximum and a stable minimum beyond
    it are passed over (Gent 97 at ``Φ̂ = 0.25051``: a wiggle at λ0 4.50–4.53 before the stable minimum at 5.84;
    review, helper-83)."""
    from .equilibria import zone_index_on_curve

    a = _snap_maximum(curve)
    if a is None:
        return None
    for b in curve.pressure_extrema():
        b = float(b)
        if b <= a or not (curve.dp(b - 1e-9) < 0 < curve.dp(b + 1e-9)):
            continue
        if curve.dv(b) > 0 and zone_index_on_curve(curve, b) == 0:
            return a, b
    return None


def _limit_pressures(
    model, phi_hat: float, lo, hi, settings: SolverSettings, maxima=(True, False)
) -> tuple[np.ndarray, np.ndarray]:
    """The pressure maximum in ``[lo[0], hi[0]]`` and minimum in ``[lo[1], hi[1]]`` (pole stretches; ``maxima`` says
    which bracket holds which kind, by default these two) at ``phi_hat``, located on exact states as
    :func:`~coexist.curves.pressure_volume_curve` locates limit points (:func:`chebyshev_extremum` of ``p̂(λ0)``,
    value settled to ``rtol/2``, location to ``limit_point_xtol``) and shot there: ``(λ0, p̂)``. NaN where the
    extremum lies at an end of its bracket (none inside) or no state is valid there."""
    lo, hi = np.asarray(lo, dtype=float), np.asarray(hi, dtype=float)

    def p_of(x):
        s = solve_states(model, x, phi_hat, settings)
        return np.where(s.ok, s.p_hat, np.nan)

    x, _ = chebyshev_extremum(
        p_of,
        lo,
        hi,
        list(maxima),
        ftol=0.5 * settings.rtol,
        xtol=settings.limit_point_xtol,
        nodes=settings.limit_point_nodes,
    )
    s = solve_states(model, x, phi_hat, settings)
    # an interior extremum: the exact slope dp̂/dλ0 rises into it and falls out of it at the bracket's ends (the
    # interpolant of a monotone stretch has its extremum just inside an end: review, helper-62)
    ends = solve_states(model, np.r_[lo, hi], phi_hat, settings, derivatives=True)
    slope = np.where(ends.ok, StateDerivatives.of(ends).dp_dl0, np.nan)
    k = lo.size
    sign = np.where(np.asarray(maxima, dtype=bool), 1.0, -1.0)
    turns = (sign * slope[:k] > 0) & (sign * slope[k:] < 0)
    inside = s.ok & (x > lo) & (x < hi) & turns
    return x, np.where(inside, s.p_hat, np.nan)


def _snap_maximum(curve: ZoneCurve):
    """The first pressure maximum (``u``) of a curve whose states rise in volume and are stable at their volume there,
    or None: the snap-through of the unbulged branch under pressure control, a limit of stability whether a stable
    branch follows it or not (neo-Hookean zones: none follows; review, helper-82)."""
    from .equilibria import zone_index_on_curve

    for a in curve.pressure_extrema():
        a = float(a)
        if curve.dp(a - 1e-9) > 0 and curve.dp(a + 1e-9) < 0:
            if curve.dv(a) > 0 and zone_index_on_curve(curve, a) == 0:
                return a
            return None  # the first maximum is not such a limit: nothing later is
    return None


def _exact_snap(model, curve: ZoneCurve, ua: float, settings: SolverSettings):
    """:func:`_exact_spinodals` for a maximum alone (no minimum follows): ``(p̂, error, note)``."""
    h = float(np.max(np.diff(curve.grid)))
    span_lo, span_hi = curve.span
    lo = curve.to_stretch(np.array([max(ua - h, span_lo)]))
    hi = curve.to_stretch(np.array([min(ua + h, span_hi)]))
    try:
        _, p = _limit_pressures(model, curve.phi_hat, lo, hi, settings, maxima=(True,))
        _, pt = _limit_pressures(model, curve.phi_hat, lo, hi, tight_settings(settings), maxima=(True,))
    except ValueError as exc:
        return np.nan, np.nan, f"the snap-through was not located on the exact states: {exc}"
    err = measured_error(p[0], pt[0], settings.rtol)
    if not np.isfinite(err):
        return np.nan, np.nan, "the snap-through is not an interior limit point of the exact states: left out"
    return float(p[0]), float(err), None


def _exact_spinodals(model, curve: ZoneCurve, loop, settings: SolverSettings):
    """The spinodal pressures of ``curve``'s loop (``(u_max, u_min)`` on its splines) as exact limit points,
    each in a bracket of one grid spacing either side of its spline location (within the curve, not past the
    midpoint between the two), and their errors located again at ``rtol/100``: ``(p̂, error)`` arrays of the
    maximum and the minimum, NaN where a limit point is not found on the exact states (a note says why)."""
    ua, ub = (float(x) for x in loop)
    h = float(np.max(np.diff(curve.grid)))
    span_lo, span_hi = curve.span
    mid = 0.5 * (ua + ub)
    u_lo = np.array([max(ua - h, span_lo), max(ub - h, mid)])
    u_hi = np.array([min(ua + h, mid), min(ub + h, span_hi)])
    lo, hi = curve.to_stretch(u_lo), curve.to_stretch(u_hi)
    try:
        x, p = _limit_pressures(model, curve.phi_hat, lo, hi, settings)
        _, pt = _limit_pressures(model, curve.phi_hat, lo, hi, tight_settings(settings))
    except ValueError as exc:
        return np.full(2, np.nan), np.full(2, np.nan), f"a spinodal was not located on the exact states: {exc}"
    err = np.array([measured_error(a, b, settings.rtol) for a, b in zip(p, pt)])
    note = None
    if not np.all(np.isfinite(err)):
        missing = " and ".join(k for k, e in zip(("maximum", "minimum"), err) if not np.isfinite(e))
        note = (
            f"the pressure {missing} of the curve's loop is not an interior limit point of the exact states near "
            f"λ0 = {float(curve.to_stretch(ua)):.6g}..{float(curve.to_stretch(ub)):.6g} (at the end of its bracket, "
            "or no valid state there): its spinodal is left out"
        )
    return np.where(np.isfinite(err), p, np.nan), err, note


#: a loop at the bisected voltage counts as merging when its maximum and minimum lie within this many
#: grid spacings (in ``u``) of each other and both lie this far inside the curve's range; a true merge
#: bisected to :data:`CRITICAL_XTOL` leaves them ``O(√CRITICAL_XTOL)`` apart, a fraction of one spacing
MERGE_SPACINGS = 4


def _loop_change(curve: ZoneCurve, loop, edge: float, appears: bool) -> str | None:
    """None if the loop of ``curve`` (at the voltage ``edge`` where it appears or disappears) is a merging
    pair of extrema; otherwise the note that says what happens there instead."""
    ua, ub = loop
    lo, hi = curve.span
    h = float(np.max(np.diff(curve.grid)))
    la, lb = (float(curve.to_stretch(x)) for x in (ua, ub))
    at_start, at_end = ua - lo <= MERGE_SPACINGS * h, hi - ub <= MERGE_SPACINGS * h
    if ub - ua <= MERGE_SPACINGS * h and not (at_start or at_end):
        return None
    where = f"where the valid states end ({curve.stopped_because})" if curve.stopped_because else "searched"
    verb = "enters" if appears else "leaves"
    if at_end:
        what = (
            f"as Φ̂ rises the pressure minimum {verb} the pole-stretch range {where} at its end, "
            f"λ0 = {float(curve.to_stretch(hi)):.6g}"
        )
    elif at_start:
        what = (
            f"as Φ̂ rises the pressure maximum {verb} the pole-stretch range {where} at its start, "
            f"λ0 = {float(curve.to_stretch(lo)):.6g}"
        )
    else:
        what = f"the loop {'appears' if appears else 'ends'} with its maximum and minimum apart"
    return (
        f"no critical point at Φ̂ ≈ {edge:.8f}: {what}; the pressure maximum (λ0 = {la:.6g}) and minimum "
        f"(λ0 = {lb:.6g}) do not merge there"
    )


def _critical_point(model, phi_bracket, stretch_bracket, settings: SolverSettings):
    """The critical point on the exact equations: the root in ``Φ̂`` of

        m(Φ̂) = min over λ0 in ``stretch_bracket`` of ∂p̂/∂λ0(λ0, Φ̂)

    (exact derivatives of the shooting, minimised by :func:`chebyshev_extremum`; ``m < 0`` where the
    curve has a loop, ``m > 0`` where it rises throughout). At the root ``λc``, the argmin, has
    ``∂p̂/∂λ0 = 0`` and ``∂²p̂/∂λ0² = 0``: the pressure maximum and minimum merge. Returns
    ``(Φ̂c, p̂c, λc, ∂p̂/∂λ0 at it, error estimate of Φ̂c)``, the estimate
    ``2 max(|∂p̂/∂λ0|, rtol) / |dm/dΦ̂|`` with the slope from the bracket's ends (a factor 2 for its
    curvature); raises ValueError when a
    state fails or the ends do not bracket a sign change."""
    lo, hi = (np.array([x]) for x in stretch_bracket)
    argmin: dict = {}

    def dp_dl0(x, phi):
        s = solve_states(model, x, phi, settings, derivatives=True)
        return np.where(s.ok, StateDerivatives.of(s).dp_dl0, np.nan)

    def m(phi):
        x, v = chebyshev_extremum(
            lambda x: dp_dl0(x, phi),
            lo,
            hi,
            [False],
            ftol=0.5 * settings.rtol,
            xtol=settings.limit_point_xtol,
            nodes=settings.limit_point_nodes,
        )
        argmin[phi] = float(x[0])
        return float(v[0])

    a, b = (float(x) for x in phi_bracket)
    ma, mb = m(a), m(b)
    root = bracketed_root(
        lambda x, idx: np.array([m(float(x[0]))]),
        a,
        b,
        ma,
        mb,
        xtol=CRITICAL_XTOL,
        ftol=settings.residual_tol,
    )
    if not root.converged[0]:
        raise ValueError(f"the critical voltage did not converge (bracket {root.lo[0]:.10g}..{root.hi[0]:.10g})")
    phic = float(root.x[0])
    lc = argmin[phic]
    if not (lo[0] < lc < hi[0]):
        raise ValueError(f"the merging point λ0 = {lc:.6g} lies at the end of the bracket searched")
    s = solve_states(model, [lc], phic, settings, derivatives=True)
    if not s.ok[0]:
        raise ValueError(f"no valid state at λ0 = {lc:.6g}, Φ̂ = {phic:.8g}")
    slope = float(StateDerivatives.of(s).dp_dl0[0])
    error = 2 * max(abs(slope), settings.rtol) * abs(b - a) / abs(mb - ma)
    return phic, float(s.p_hat[0]), lc, slope, error


def phase_diagram(model, phi_values, pole_stretch_max: float, settings: SolverSettings | None = None) -> PhaseDiagram:
    """Spinodals, binodal and critical point of one zone over the voltages ``phi_values``.

    Each voltage gets its own directly shot curve (``settings.phase_diagram_points`` states in
    ``u = √(λ0 − λpre)``), which gives the first guesses only: the spinodals are the pressure maximum
    and minimum located again on exact states (:func:`_exact_spinodals`, ``∂p̂/∂λ0 = 0``), the binodal
    is :func:`maxwell_coexistence` on the curve polished on exact states (:func:`exact_coexistence`),
    each with its error measured at ``rtol/100``. Where the curve gains or loses its loop (a
    pressure maximum followed by a minimum) between neighbouring voltages, the change is bisected on
    the curves (to 1e-8 in ``Φ̂``) and classified: a critical point only if the maximum and minimum
    merge there (within ``MERGE_SPACINGS`` grid spacings of each other, inside the curve's range), not
    if one of them merely crosses an end of the pole-stretch range (a note says so). A merge is then
    solved on the exact equations: ``Φ̂c`` is the root of
    ``m(Φ̂) = min_λ0 ∂p̂/∂λ0(λ0, Φ̂)`` (exact shooting derivatives), so that at ``(λc, Φ̂c)``

        ∂p̂/∂λ0 = 0   and   ∂²p̂/∂λ0² = 0.

    Parameters
    ----------
    model : MembraneModel
        A membrane with electrostatics (or only ``Φ̂ = 0`` in ``phi_values``).
    phi_values : array_like
        Normalised voltages ``Φ̂ ≥ 0`` in order (the critical point is bracketed between neighbours).
    pole_stretch_max : float
        Largest pole stretch of each curve (the grid starts at ``1.002 λpre``).
    settings : SolverSettings, optional
        Tolerances and ``phase_diagram_points``; default ``SolverSettings()``.

    Returns
    -------
    PhaseDiagram
        NaN where a voltage has no loop or no coexistence (why in ``notes``); ``critical_point`` the
        first merge along ``phi_values`` (``(Φ̂c, p̂c, λc)``, a state shot exactly at ``(λc, Φ̂c)``), or
        None, with a note for every change between loop and no loop that is not one.

    Raises
    ------
    SceneError
        For a negative voltage, or a voltage on a model without electrostatics.
    SolverError
        If a Maxwell solve on the splines fails numerically (a :class:`ModelRangeError` is recorded in
        ``notes``; so is a spline solution that does not converge on the exact states, e.g. next to the
        critical point, and a spinodal not found on them: their pressures stay NaN).
    """
    settings = settings_or_default(settings)
    membrane_model(model)
    phi_values = real_array(phi_values, "phi_values", lo=0.0)
    pole_stretch_max = real(pole_stretch_max, "pole_stretch_max")
    if not (np.isfinite(pole_stretch_max) and pole_stretch_max > model.prestretch * (1 + 2e-3)):
        raise SceneError(
            f"pole_stretch_max must exceed the prestretch by more than 0.2 %, got {pole_stretch_max!r}",
            "pole_stretch_max",
        )
    phi_values = np.asarray(phi_values, dtype=float)
    pre = model.prestretch
    states, notes = [], []
    lock = model.elasticity.locking_stretch
    if lock is not None and pole_stretch_max > settings.locking_margin * lock:
        # a grid laid far past where the chains lock puts a few of its points on the curve: the splines' loops are
        # then wrong (review, helper-62: Gent Jlim 97 to λ0 = 100 gave a spinodal 1.6 % off with a 1.8e-10 error)
        end = settings.locking_margin * lock
        notes.append(
            f"pole_stretch_max = {pole_stretch_max:.6g} lies beyond the model's range; the curves end at "
            f"λ0 = {end:.6g} (locking_margin times the Gent locking stretch)"
        )
        pole_stretch_max = end
    u = np.linspace(np.sqrt(2e-3 * pre), np.sqrt(pole_stretch_max - pre), settings.phase_diagram_points)
    smax, smin, bino, emax, emin, ebino = (np.full(phi_values.size, np.nan) for _ in range(6))
    loops: list = [None] * phi_values.size

    def curve_at(phi):
        return ZoneCurve.compute(model, phi, pre + u**2, settings)

    for i, phi in enumerate(phi_values):
        try:
            c = curve_at(phi)
        except ModelRangeError as exc:
            notes.append(f"Φ̂ = {phi:.6g}: {exc}")
            continue
        loop = _loop(c)
        if loop is None:
            snap = _snap_maximum(c)
            if snap is not None:  # the unbulged branch's limit all the same, with no stable branch beyond it
                smax[i], emax[i], why = _exact_snap(model, c, snap, settings)
                if why is not None:
                    notes.append(f"Φ̂ = {phi:.6g}: {why}")
            continue
        loops[i] = tuple(float(c.to_stretch(x)) for x in loop)
        (smax[i], smin[i]), (emax[i], emin[i]), why = _exact_spinodals(model, c, loop, settings)
        if why is not None:
            notes.append(f"Φ̂ = {phi:.6g}: {why}")
        try:
            guess = maxwell_coexistence(c, settings)
        except ModelRangeError as exc:
            notes.append(f"Φ̂ = {phi:.6g}: {exc}")
            continue
        try:
            co = exact_coexistence(model, guess, settings)
        except SolverError as exc:  # e.g. next to the critical point: no number rather than the spline's
            notes.append(
                f"Φ̂ = {phi:.6g}: the binodal is left out, its spline solution not converged on exact states: {exc}"
            )
            continue
        bino[i], ebino[i] = co.p_hat, co.p_hat_error
        states.append(co)
    has_loop = np.array([lp is not None for lp in loops], dtype=bool)
    if not has_loop.any():
        notes.append(
            f"no voltage in Φ̂ = {phi_values.min():.4g}..{phi_values.max():.4g} has a pressure maximum followed by a "
            + (
                "minimum with a stable branch beyond it: no lower spinodal, no coexistence (no second stable "
                "branch up to the end of the model's range, "
                f"λ0 = {pole_stretch_max:.4g}; the snap-through, where there is one, is the upper spinodal)"
                if np.isfinite(smax).any()
                else "minimum: no spinodals, no coexistence (the curve rises monotonically up to the end of the "
                f"model's range, λ0 = {pole_stretch_max:.4g}, or has no second stable branch)"
            )
        )
    critical = None
    change = np.flatnonzero(has_loop[:-1] != has_loop[1:])
    for j in change:
        with_loop_hi = bool(has_loop[j + 1])

        def like_lo(phi: float, with_loop_hi=with_loop_hi) -> bool | None:
            try:
                return (_loop(curve_at(phi)) is not None) != with_loop_hi
            except ModelRangeError:
                return None  # no curve there: keep the bracket found so far

        lo, hi, _ = bisect(like_lo, phi_values[j], phi_values[j + 1], xtol=CRITICAL_XTOL)
        edge = hi if with_loop_hi else lo
        try:
            c = curve_at(edge)
            loop = _loop(c)
        except ModelRangeError:
            loop = None
        if loop is None:
            continue
        other = _loop_change(c, loop, edge, appears=with_loop_hi)
        if other is not None:
            notes.append(other)
            continue
        la, lb = loops[j + 1] if with_loop_hi else loops[j]
        w = 0.25 * (lb - la)
        bracket = (max(la - w, pre * (1 + 1e-3)), min(lb + w, pole_stretch_max))
        try:
            phic, pc, lc, slope, error = _critical_point(model, (phi_values[j], phi_values[j + 1]), bracket, settings)
        except ValueError as exc:
            notes.append(
                f"the pressure maximum and minimum merge near Φ̂ ≈ {edge:.8f} on the curves, but the exact "
                f"critical point was not found: {exc}"
            )
            continue
        critical = (phic, pc, lc)
        notes.append(
            f"critical point at Φ̂ = {phic:.8f} (± {error:.1e}), λ0 = {lc:.6f}: the pressure maximum and minimum merge "
            "(solved on the "
            f"exact equations: dp̂/dλ0 = {slope:.1e} there, its minimum over λ0); "
            + (
                "bulged and unbulged states coexist above this voltage, not below (the loop opens there)"
                if with_loop_hi
                else "bulged and unbulged states coexist below this voltage, not above (the loop closes there)"
            )
        )
        break
    return PhaseDiagram(phi_values, smax, smin, bino, states, critical, notes, emax, emin, ebino)
