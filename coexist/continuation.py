"""Pseudo-arclength continuation of an equilibrium configuration in the voltage, with exact events.

A configuration's equilibria (:class:`~coexist.equilibria.GroupSystem`) form curves in the space of
``z = (u1 … uM, w Φ̂)`` (``w`` scales the voltage so that a step means the same in every direction).
A :class:`Branch` is one such curve traced from a seed in both directions:

- **predictor**: the unit tangent ``t`` (null vector of the Jacobian ``∂r/∂z``, oriented along the
  trace) times the step ``h``;
- **corrector**: Newton's method on the exact residuals plus the arclength condition
  ``t · (z − z_prev) = h``, every residual evaluated by direct shooting and every Jacobian from the
  variational equations (:mod:`coexist.shooting`), all points of a step evaluated in one call;
- **adaptive step**: ``h`` grows after quick convergence and halves after slow or failed convergence
  or a sharp turn (the driver says so in the branch's notes when it gives up).

The curve is traced through folds in ``Φ̂`` (the tangent's voltage component changes sign) and
through symmetric branch points (two groups' pole stretches cross). Between two accepted points,
**events** are located exactly, as roots along the curve of a smooth function, each on converged
states (:func:`locate`):

====================  ==========================================================================
``fold``              ``tΦ = 0``: a turning point in the voltage (a spinodal of the configuration)
``split``             ``dp̂/du = 0`` in a group of two or more zones: its zones can move against
                      each other (a symmetric branch point; the ``k``-bulged branches leave there)
``volume_fold``       ``dV̂/du = 0`` of a group: a zone passes a volume fold (its own index changes)
``merge``             two groups' pole stretches cross: the branch meets the homogeneous (or a
                      coarser) configuration there
``breakdown``         the largest field reaches the breakdown field (only when a scene gives one)
``range_end``         the states stop being valid (wrinkling, Gent locking, no equilibrium): the
                      boundary between the last valid state and the first invalid one is bisected
``window``            the voltage leaves the window the branch was asked for
====================  ==========================================================================

Stability is evaluated at every point (closed form, :mod:`coexist.equilibria`); the zone's own
index is carried along the branch and updated at every ``volume_fold`` by Maddocks' rule.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass, field

import numpy as np

from .effects import Breakdown
from .equilibria import (
    Configuration,
    Equilibrium,
    GroupSystem,
    Residual,
    failure_reason,
    make_equilibrium,
    scale_starts,
    shoot_groups,
)
from .errors import SolverError
from .numerics.roots import bracketed_root, newton
from .shooting import STEP_LIMIT, WRINKLED

# The driver's step control and tolerances are in SolverSettings (initial_step, max_step, min_step,
# max_turn, max_newton, max_points, loose_tolerance, chord_below; newton_tol and event_tol from rtol).
#: weight of the voltage in the arclength, ``z = (u1 … uM, w Φ̂)``: a change of 0.01 in Φ̂ counts like
#: 0.1 in ``u`` (fixed, so that the points traced do not depend on the voltage window asked for)
VOLTAGE_WEIGHT = 10.0


@dataclass
class Point:
    """One converged equilibrium on a branch: ``z``, the unit tangent and the state."""

    z: np.ndarray
    tangent: np.ndarray
    eq: Equilibrium
    dp_du: np.ndarray
    dv_du: np.ndarray
    index: tuple
    stable: bool
    s: float = 0.0  # arclength coordinate along the branch (seed at 0)

    @property
    def phi(self) -> float:
        """The point's voltage ``Φ̂``."""
        return self.eq.phi_hat


@dataclass
class Event:
    """An event located on a branch: between points ``i`` and ``i + 1`` (in branch order)."""

    kind: str
    phi_hat: float
    eq: Equilibrium  # the state there (for an approximate event, that of the nearer point)
    z: np.ndarray
    s: float
    group: int | None = None
    error: float = 0.0  # estimated error of phi_hat
    note: str = ""
    stable_before: bool | None = None  # along increasing s
    stable_after: bool | None = None
    tangent: np.ndarray | None = field(default=None, repr=False)
    measured: bool = False  # True once ``error`` includes the re-location at a tighter tolerance
    # the integration step budget its states needed, where larger than the settings' (an end approached by
    # states whose integration takes ever more steps: Tracer._budget_end); its re-location uses it too
    max_steps: int | None = None


@dataclass
class Branch:
    """A traced curve of one configuration: points in order of arclength, events between them."""

    system: GroupSystem
    points: list
    events: list
    ends: tuple = (None, None)  # the events (or notes) that end the branch at low and high s
    notes: list = field(default_factory=list)

    @property
    def configuration(self) -> Configuration:
        """The configuration traced (as set up; a point's own equilibrium orders its groups by ``u``)."""
        return self.system.configuration


# --- the corrector --------------------------------------------------------------------------------
@dataclass
class Corrected:
    """Result of a batched corrector: per point the converged ``z``, success and, if failed, why."""

    z: np.ndarray
    ok: np.ndarray
    reason: list
    res: Residual  # the converged points' residuals and states (rows ``rows``)
    rows: np.ndarray  # row of each point in ``res`` (−1 if failed)
    failed_states: dict = field(default_factory=dict)  # point -> (res, row, status code) where a state failed


def _scaled_jacobian(J, w):
    Js = J.copy()
    Js[..., -1] /= w
    return Js


def correct(
    system: GroupSystem,
    z0,
    normals,
    targets,
    w: float,
    max_iter: int | None = None,
    loose: bool = False,
    formal: bool = False,
    chord: bool = False,
) -> Corrected:
    """Newton's method for ``r(z) = 0``, ``n · z = target`` at ``P`` points at once.

    ``z0`` ``(P, M + 1)`` initial guesses, ``normals`` ``(P, M + 1)`` constraint normals (the previous
    tangent for pseudo-arclength, the voltage axis for a fixed voltage), ``targets`` ``(P,)``. A point
    converges when its Newton step is below ``settings.newton_tol`` (``loose``: below
    ``settings.loose_tolerance``), or when its step stops shrinking at the shooting's noise level; it fails
    when a state is invalid, the step grows, or the iterations run out. The converged state is the
    last one evaluated (no extrapolation): its residual is what :class:`Equilibrium` reports.
    ``chord``: once the steps are below ``settings.chord_below``, evaluate the residual alone and reuse the
    last Jacobian (the converged state's own derivatives are then those of the last iterate evaluated with
    derivatives, which may be several iterates back).

    Converged (not loose) means a step in ``z`` below ``settings.newton_tol`` *and* pressure residuals
    below ``settings.residual_tol · (1 + |p̂_gas|)``; ``loose`` uses ``settings.loose_tolerance`` for both.
    The Jacobian's ``Φ̂`` column is divided by ``w`` (the unknowns are ``z = (u1 … uM, wΦ̂)``).

    Parameters
    ----------
    system : GroupSystem
        The configuration's equations.
    z0 : array_like, shape (P, M + 1)
        Initial guesses ``z = (u1 … uM, wΦ̂)``.
    normals : array_like, shape (P, M + 1)
        Normal ``n`` of each point's constraint ``n · z = target``.
    targets : array_like, shape (P,)
        Right-hand sides of the constraints.
    w : float
        Voltage weight of ``z`` (:data:`VOLTAGE_WEIGHT`).
    max_iter : int, optional
        Newton iterations (default ``settings.max_newton``).
    loose : bool, optional
        Converge to ``settings.loose_tolerance`` only (points along a branch).
    formal : bool, optional
        Shoot formally continued states (through a vanishing hoop tension; for locating wrinkling).
    chord : bool, optional
        Reuse the last Jacobian once the steps are small.

    Returns
    -------
    Corrected
        ``z`` (the last iterate of every point), ``ok``, a ``reason`` per failed point (``"invalid state:
        …"``, ``"singular Newton matrix"``, ``"Newton diverges"``, ``"Newton did not converge"``), the
        converged points' residuals gathered in ``res`` (row ``rows[i]``; −1 for a failed point) and, in
        ``failed_states``, ``(res, row, status code)`` of each point that failed on an invalid state.
    """
    z = np.array(z0, dtype=float, copy=True)
    P, M1 = z.shape
    M = M1 - 1
    normals = np.asarray(normals, dtype=float)
    targets = np.asarray(targets, dtype=float)
    settings = system.settings
    max_iter = settings.max_newton if max_iter is None else max_iter
    tol = settings.loose_tolerance if loose else settings.newton_tol
    ok = np.zeros(P, dtype=bool)
    done = np.zeros(P, dtype=bool)
    reason = [""] * P
    prev_step = np.full(P, np.inf)
    rows = np.full(P, -1)
    last_res = None
    keep: dict = {}
    jac = np.full((P, M, M1), np.nan)
    slopes = np.full((P, 4, M), np.nan)  # dp/du, dV/du, dp/dΦ̂, dV/dΦ̂ of the last full evaluation
    for it in range(max_iter):
        act = np.flatnonzero(~done)
        if act.size == 0:
            break
        use_chord = chord and np.all(prev_step[act] <= settings.chord_below)
        res = system.residual(z[act, :M], z[act, M] / w, formal, derivatives=not use_chord)
        st_ = res.states
        if use_chord:
            res.J = jac[act]
            # the derivatives of the last iterate shot with them (every step since below chord_below) stand in
            st_.dp_du, st_.dv_du, st_.dp_dphi, st_.dv_dphi = (slopes[act, k].copy() for k in range(4))
        else:
            jac[act] = res.J
            for k, name in enumerate(("dp_du", "dv_du", "dp_dphi", "dv_dphi")):
                slopes[act, k] = getattr(st_, name)
        st = res.states
        valid = st.ok
        for jj, i in enumerate(act):
            if not valid[jj]:
                done[i] = True
                code = int(st.status[jj][st.status[jj] != 0][0])
                reason[i] = f"invalid state: {failure_reason(code)[1]}"
                keep[i] = (res, jj, code)
        A = np.empty((act.size, M1, M1))
        A[:, :M, :] = _scaled_jacobian(res.J, w)
        A[:, M, :] = normals[act]
        b = np.empty((act.size, M1))
        b[:, :M] = res.r
        b[:, M] = np.einsum("ij,ij->i", normals[act], z[act]) - targets[act]
        with np.errstate(all="ignore"):
            try:
                step = np.linalg.solve(A, -b[..., None])[..., 0]
            except np.linalg.LinAlgError:
                step = np.full_like(b, np.nan)
                for jj in range(act.size):
                    try:
                        step[jj] = np.linalg.solve(A[jj], -b[jj])
                    except np.linalg.LinAlgError:
                        pass
        size = np.max(np.abs(step), axis=1)
        # the pressure residual too: a tiny step in u can still leave a large pressure mismatch where the
        # gas makes a zone's volume very sensitive (∂r/∂u ≈ 150 for the tricircle's bulged zone)
        small_r = np.max(np.abs(res.r), axis=1) <= (settings.loose_tolerance if loose else settings.residual_tol) * (
            1 + np.abs(res.gas_pressure)
        )
        for jj, i in enumerate(act):
            if done[i]:
                continue
            if not np.isfinite(size[jj]):
                done[i] = True
                reason[i] = "singular Newton matrix"
                continue
            if (size[jj] <= tol and small_r[jj]) or (
                it >= 2 and size[jj] >= 0.5 * prev_step[i] and size[jj] <= 1e3 * tol
            ):
                done[i] = ok[i] = True
                keep[i] = (res, jj, None)
                continue
            if it >= 2 and size[jj] > 2 * prev_step[i]:
                done[i] = True
                reason[i] = "Newton diverges"
                continue
            prev_step[i] = size[jj]
            z[i] += step[jj]
        last_res = res
    for i in np.flatnonzero(~done):
        reason[i] = "Newton did not converge"
    # gather the converged points' residual rows into one Residual (cheap views)
    conv = np.flatnonzero(ok)
    if conv.size:
        merged_res = _gather([keep[i] for i in conv])
        rows[conv] = np.arange(conv.size)
    else:
        merged_res = last_res
    return Corrected(z, ok, reason, merged_res, rows, {i: keep[i] for i in keep if not ok[i]})


def solve_at_voltage(tracer: Tracer, z_guess, phi: float, loose: bool = False, chord: bool = False) -> Corrected:
    """Newton's method at a fixed voltage ``Φ̂`` from ``z_guess`` (its voltage entry is replaced).

    Parameters
    ----------
    tracer : Tracer
        Gives the system, ``M`` and the voltage weight ``w``.
    z_guess : array_like, shape (M + 1,)
        First guess of ``z = (u1 … uM, wΦ̂)``.
    phi : float
        The voltage ``Φ̂``.
    loose : bool, optional
        Converge to ``settings.loose_tolerance`` only.
    chord : bool, optional
        Reuse the last Jacobian once the steps are small (see :func:`correct`).

    Returns
    -------
    Corrected
        One point (:func:`correct` with the constraint ``wΦ̂ = w phi``).
    """
    M = tracer.M
    z = np.array(z_guess, dtype=float, copy=True)
    z[M] = phi * tracer.w
    n = np.zeros(M + 1)
    n[M] = 1.0
    return correct(
        tracer.system, z[None, :], n[None, :], np.array([phi * tracer.w]), tracer.w, loose=loose, chord=chord
    )


def _gather(items):
    """One :class:`Residual` made of rows of several (each item ``(res, row, _)``)."""
    from .equilibria import GroupStates, Residual

    def pick(attr_get):
        values = [attr_get(r) for r, _, _ in items]
        if any(v is None for v in values):  # an optional field (None for a model that refuses wrinkling)
            return None
        return np.stack([v[j] for v, (_, j, _) in zip(values, items)])

    st_fields = {k: pick(lambda r, k=k: getattr(r.states, k)) for k in GroupStates.__dataclass_fields__}
    states = GroupStates(**st_fields)
    return Residual(
        r=pick(lambda r: r.r),
        J=pick(lambda r: r.J),
        states=states,
        total_volume=pick(lambda r: r.total_volume),
        gas_pressure=pick(lambda r: r.gas_pressure),
        gas_stiffness=pick(lambda r: r.gas_stiffness),
    )


def tangents(J, w, orient):
    """Unit null vectors of the scaled Jacobians ``J`` (``(P, M, M + 1)``), oriented along ``orient``.

    Solves ``[J_s; orient] t = e_{M+1}`` (``J_s``: ``J`` with its ``Φ̂`` column divided by ``w``), falling
    back to the last right singular vector of ``J_s`` where that system is singular.

    Parameters
    ----------
    J : ndarray, shape (P, M, M + 1)
        Jacobians ``∂r/∂(u1 … uM, Φ̂)``.
    w : float
        Voltage weight of ``z``.
    orient : ndarray, shape (P, M + 1)
        Directions the tangents are to follow (``t · orient ≥ 0``).

    Returns
    -------
    ndarray, shape (P, M + 1)
        Unit tangents in ``z = (u1 … uM, wΦ̂)``.
    """
    Js = _scaled_jacobian(J, w)
    P, M, M1 = Js.shape
    A = np.empty((P, M1, M1))
    A[:, :M, :] = Js
    A[:, M, :] = orient
    rhs = np.zeros((P, M1))
    rhs[:, M] = 1.0
    with np.errstate(all="ignore"):
        t = np.linalg.solve(A, rhs[..., None])[..., 0]
    bad = ~np.all(np.isfinite(t), axis=1)
    if bad.any():  # orient is itself (nearly) a null direction of nothing: fall back to the SVD
        for i in np.flatnonzero(bad):
            t[i] = np.linalg.svd(Js[i])[2][-1]
    t /= np.linalg.norm(t, axis=1, keepdims=True)
    flip = np.einsum("ij,ij->i", t, orient) < 0
    t[flip] *= -1
    return t


# --- the traced branch ----------------------------------------------------------------------------
def hermite(a_z, a_t, b_z, b_t, tau):
    """Cubic Hermite point between two branch points (chord parameter ``tau`` in [0, 1]).

    The tangents are scaled by the chord ``L = |b_z − a_z|``; ``tau`` outside [0, 1] extrapolates (the
    continuation's predictor).

    Parameters
    ----------
    a_z, b_z : ndarray, shape (M + 1,)
        The two points' ``z``.
    a_t, b_t : ndarray, shape (M + 1,)
        Their unit tangents, both oriented from ``a`` towards ``b``.
    tau : float
        Chord parameter: 0 at ``a``, 1 at ``b``.

    Returns
    -------
    ndarray, shape (M + 1,)
        ``z`` on the cubic.
    """
    L = float(np.linalg.norm(b_z - a_z))
    t2, t3 = tau * tau, tau * tau * tau
    return (2 * t3 - 3 * t2 + 1) * a_z + (t3 - 2 * t2 + tau) * L * a_t + (-2 * t3 + 3 * t2) * b_z + (t3 - t2) * L * b_t


#: the longest continuation step (scaled arclength) taken across a change the event functions do not locate: the
#: onset of wrinkling of a zone group, or a change of stability without an event (past a longer step the corrector
#: may land on another branch)
SHORT_STEP = 0.02


#: the voltages, relative to the onset of a wrinkled band's pull-in in the material (``Φ̂c``, where some stretch of
#: a hoop-wrinkled strip first loses its stiffness: :func:`coexist.wrinkling.band_pull_in_onset`), probed inside a
#: step of wrinkled states that crosses it: ``Φ̂c (1 + ε)``. The unstable stretches are born with zero width there and
#: widen like ``√(Φ̂ − Φ̂c)``; a state whose band spans them is found invalid once they are wider than the shooting's
#: steps (3e-7 above ``Φ̂c`` for the Gent membrane of helper-77's huge chamber, whose states are invalid over 1e-3)
ONSET_PROBE_OFFSETS = (1e-6, 1e-5, 1e-4, 1e-3)
#: a step whose voltage slope dips inside it below this fraction of its smaller end value is examined inside
DIP_FRACTION = 0.9
#: where a step is examined inside: its fractions of the chord (with the Hermite slope's minimum)
DIP_SAMPLES = (0.25, 0.5, 0.75)


def _voltage_dip(a: Point, b: Point, M: int) -> float | None:
    """Where the step ``a -> b`` may hide two folds: the chord fraction ``τ`` at which the slope of the cubic
    Hermite of ``wΦ̂`` along the step dips inside it well below the slopes at both ends, or None.

    With the chord ``L = |z_b − z_a|``, ``τ ∈ [0, 1]``, end values ``φa``, ``φb`` of ``wΦ̂`` and slopes ``fa``,
    ``fb`` (the fold function: the tangent's ``wΦ̂`` component, tangents oriented from ``a`` to ``b``), the
    Hermite derivative is the quadratic
    ``φ'(τ) = (6τ²−6τ) φa + (3τ²−4τ+1) L fa + (−6τ²+6τ) φb + (3τ²−2τ) L fb``; the step is suspect when ``fa``
    and ``fb`` have one sign and ``sign(fa) φ'(τ)/L`` has an interior minimum below
    ``DIP_FRACTION min(|fa|, |fb|)``. Near a cusp of the branch two folds can lie a few 10⁻⁶ kV apart (a
    swallowtail), far below what a step resolves: the Hermite only shows the slope dipping (measured, the
    tricircle with inner-circle electrodes of 0.9 of the radius and two passive layers: to 0.02–0.63 of the
    smaller end value). A step across both folds sees no sign change of the fold function, and a stable-only
    trace would run through the unstable piece between them onto the other stable piece. The smooth minima
    of the slope on ordinary branches are shallow (the 10⁹ ml tricircle's: to 0.9999 of it) and are left
    alone (a threshold of 1 shortened its homogeneous steps, and one of its equal-free-energy voltages then
    failed to converge at rtol/100: the states' rounding dominates ``ΔĜ`` there).
    """
    L = float(np.linalg.norm(b.z - a.z))
    if L == 0.0:
        return None
    d = b.z - a.z
    ta = a.tangent if d @ a.tangent >= 0 else -a.tangent
    tb = b.tangent if d @ b.tangent >= 0 else -b.tangent
    fa, fb = float(ta[M]), float(tb[M])
    if fa == 0.0 or fa * fb <= 0.0:
        return None  # a sign change (or a zero) at the ends: the event functions see it
    pa, pb = float(a.z[M]), float(b.z[M])
    c2 = 6 * pa + 3 * L * fa - 6 * pb + 3 * L * fb
    c1 = -6 * pa - 4 * L * fa + 6 * pb - 2 * L * fb
    c0 = L * fa
    if c2 == 0.0:
        return None  # a linear slope: its extremes are at the ends
    tv = -c1 / (2 * c2)
    if not 0.0 < tv < 1.0:
        return None
    dip = np.sign(fa) * (c2 * tv * tv + c1 * tv + c0) / L
    return float(tv) if dip < DIP_FRACTION * min(abs(fa), abs(fb)) else None


def _wrinkled(point: Point) -> tuple:
    """Which zone groups of ``point`` are hoop-wrinkled (tension-field states: smallest tension zero)."""
    return tuple(bool(t <= 0) for t in np.atleast_1d(point.eq.min_tension))


class Tracer:
    """Traces the branches of one configuration of a scene's zones.

    Parameters
    ----------
    system : GroupSystem
    phi_window : (float, float)
        Voltages between which the branch is wanted.
    breakdown : Breakdown or None
        The breakdown effect (:class:`~coexist.effects.Breakdown`); ``None``: no breakdown event.
    """

    def __init__(self, system: GroupSystem, phi_window, breakdown: Breakdown | None = None):
        self.system = system
        self.phi_lo, self.phi_hi = float(phi_window[0]), float(phi_window[1])
        self.w = VOLTAGE_WEIGHT
        self.breakdown = breakdown
        self.M = system.groups
        self.counts = np.asarray(system.configuration.counts)
        # the tight states of the last pull-in extrapolation beyond the branch's last point (pull_in_end)
        self._end_points: list = []
        # the settings' own step budget, where this tracer's was raised (with_budget, _budget_end)
        self.base_steps: int = system.settings.max_steps
        # the status code of the invalid probe just past a wrinkled band's onset (_past_band_onset, _onset_end)
        self._onset_code: int | None = None

    # points -------------------------------------------------------------------------------------------
    def _point(self, corr: Corrected, i: int, orient, index) -> Point:
        res = corr.res
        r = corr.rows[i]
        t = tangents(res.J[r : r + 1], self.w, np.asarray(orient, dtype=float)[None, :])[0]
        eq = make_equilibrium(self.system, res, r, index)
        st = res.states
        return Point(
            corr.z[i].copy(), t, eq, st.dp_du[r].copy(), st.dv_du[r].copy(), tuple(index), _is_stable(eq, index)
        )

    def _solve(self, z_guess, normal, target, orient, index, loose=False) -> Point | None:
        """One point (loose or tight) on the constraint ``normal · z = target``; None if it fails."""
        corr = correct(
            self.system,
            np.asarray(z_guess, dtype=float)[None, :],
            np.asarray(normal)[None, :],
            np.array([target]),
            self.w,
            loose=loose,
        )
        if not corr.ok[0]:
            self._last_failure = corr
            return None
        return self._point(corr, 0, orient, index)

    def event_values(self, pt: Point) -> dict:
        """The smooth functions whose roots are events, at one point.

        Parameters
        ----------
        pt : Point
            A converged point of this tracer's configuration.

        Returns
        -------
        dict of str to float
            ``"fold"``: the tangent's ``wΦ̂`` component; ``"split:j"``: ``dp̂/du`` of group ``j`` (groups of
            ``nj ≥ 2`` only); ``"volume_fold:j"``: ``dV̂/du`` of group ``j``; ``"merge:j"``: ``u_{j+1} − uj``;
            ``"breakdown"``: ``Ê_max − Êb`` of the largest field (when a breakdown is given).
        """
        M = self.M
        u = pt.z[:M]
        vals = {"fold": pt.tangent[M]}
        for j in range(M):
            if self.counts[j] >= 2:
                vals[f"split:{j}"] = pt.dp_du[j]
            vals[f"volume_fold:{j}"] = pt.dv_du[j]
        for j in range(M - 1):
            vals[f"merge:{j}"] = u[j + 1] - u[j]
        if self.breakdown is not None:
            vals["breakdown"] = self.breakdown.margin(max(pt.eq.max_field))
        return vals

    def seed(self, z, index=None) -> Point:
        """Converge a seed at fixed voltage (tightly) and return it as a point.

        Parameters
        ----------
        z : array_like, shape (M + 1,)
            First guess ``(u1 … uM, wΦ̂)``; its voltage is kept.
        index : sequence of int, optional
            Each group's zone index (:func:`~coexist.equilibria.zone_index`; default all 0).

        Returns
        -------
        Point
            The converged seed, its tangent oriented towards increasing ``Φ̂``.

        Raises
        ------
        SolverError
            If Newton's method does not converge from ``z`` (the message gives why).
        """
        z = np.asarray(z, dtype=float)
        M = self.M
        n = np.zeros(M + 1)
        n[M] = 1.0
        index = tuple(index) if index is not None else (0,) * M
        p = self._solve(z, n, z[M], n, index)
        if p is None:
            raise SolverError(
                f"no equilibrium of {self.system.configuration.label} near the seed at "
                f"Φ̂ = {z[M] / self.w:.6g}: {self._last_failure.reason[0]}"
            )
        return p

    def trace(self, seed: Point, stable_only: bool = False) -> Branch:
        """Trace the branch through ``seed`` in both directions.

        ``stable_only``: stop each direction at the first event where stability is lost (located
        exactly; it becomes the branch's end), so the branch is one stable segment.

        With ``stable_only`` a direction also stops at a ``merge`` or a ``breakdown``. Every direction stops
        at a ``range_end`` or at the edge of the voltage window (a ``window`` event), or with a note (no end
        event) when the corrector fails at ``settings.min_step`` or after ``settings.max_points`` points.

        Parameters
        ----------
        seed : Point
            A converged point (:meth:`seed`).
        stable_only : bool, optional
            Trace one stable segment only (default False: the whole branch in the window).

        Returns
        -------
        Branch
            Points in order of arclength (the seed at ``s = 0``), the events between them, the ends at
            low and high ``s`` (an :class:`Event` or None) and the notes.
        """
        self.stable_only = stable_only
        if self.phi_hi <= self.phi_lo:  # a window of one voltage (a scene without voltage): the seed alone
            edge = [
                Event(
                    kind="window",
                    phi_hat=self.phi_lo,
                    eq=seed.eq,
                    z=seed.z,
                    s=0.0,
                    stable_before=seed.stable,
                    stable_after=seed.stable,
                    note="the window is one voltage",
                )
                for _ in range(2)
            ]
            return Branch(self.system, [seed], [], tuple(edge), [])
        fwd, fev, fend, fnotes = self._one_way(seed, +1)
        bwd, bev, bend, bnotes = self._one_way(seed, -1)
        for p in bwd:
            p.s = -p.s
            p.tangent = -p.tangent
        for e in bev + ([bend] if isinstance(bend, Event) else []):
            e.s = -e.s
            e.stable_before, e.stable_after = e.stable_after, e.stable_before
        points = list(reversed(bwd)) + [seed] + fwd
        events = sorted(bev + fev, key=lambda e: e.s)
        return Branch(self.system, points, events, (bend, fend), bnotes + fnotes)

    #: the ends of a branch itself (a whole-branch :meth:`trace` stops there); past any other end of a stable
    #: segment (a fold, a split, a volume fold, a merge, a breakdown: the stability changes, the branch goes on)
    #: :meth:`extend` continues it
    BRANCH_ENDS = ("range_end", "window")

    def extend(self, segment: Branch) -> Branch:
        """The whole branch through a traced stable ``segment`` (:meth:`trace` with ``stable_only``): its points
        and events as they are, continued past each end where the branch goes on (an event not of a kind in
        :data:`BRANCH_ENDS`: the stability changes there, the branch does not end) as :meth:`trace` without
        ``stable_only`` would continue it, from the segment's last point on that side. The same branch as a
        whole-branch :meth:`trace`, without tracing the stable part and locating its ends again (a pull-in end
        costs tens of milliseconds).

        Parameters
        ----------
        segment : Branch
            A stable segment of this tracer's configuration (``StableSegment.branch``).

        Returns
        -------
        Branch
            Points in order of arclength (continuing the segment's ``s``), events and ends as :meth:`trace`.
        """
        saved = getattr(self, "stable_only", False)
        self.stable_only = False
        try:
            points, events = list(segment.points), list(segment.events)
            ends = list(segment.ends)
            notes = list(segment.notes)
            for side, sign in ((0, -1), (1, +1)):
                end = ends[side]
                if not isinstance(end, Event) or end.kind in self.BRANCH_ENDS:
                    continue
                seed = points[0] if side == 0 else points[-1]
                pts, evs, new_end, new_notes = self._one_way(seed, sign)
                for p in pts:
                    p.s = seed.s + sign * p.s
                    p.tangent = sign * p.tangent
                for e in evs + ([new_end] if isinstance(new_end, Event) else []):
                    e.s = seed.s + sign * e.s
                    if sign < 0:
                        e.stable_before, e.stable_after = e.stable_after, e.stable_before
                points = list(reversed(pts)) + points if side == 0 else points + pts
                events.extend(evs)
                ends[side] = new_end
                notes.extend(new_notes)
            events.sort(key=lambda e: e.s)
            return Branch(self.system, points, events, (ends[0], ends[1]), notes)
        finally:
            self.stable_only = saved

    def _one_way(self, seed: Point, sign: int):
        pts: list[Point] = []
        events: list[Event] = []
        notes: list[str] = []
        cur = Point(seed.z.copy(), sign * seed.tangent, seed.eq, seed.dp_du, seed.dv_du, seed.index, seed.stable, 0.0)
        prev = None
        cfg = self.system.settings
        h = cfg.initial_step
        end = None
        while True:
            if len(pts) >= cfg.max_points:
                notes.append(f"continuation stopped after {cfg.max_points} points at Φ̂ = {cur.phi:.8g}")
                break
            new = self._solve(
                self._predict(prev, cur, h), cur.tangent, cur.tangent @ cur.z + h, cur.tangent, cur.index, loose=True
            )
            if new is None:
                failure = self._last_failure
                codes = [c[2] for c in getattr(failure, "failed_states", {}).values() if c[2] is not None]
                invalid = bool(codes)
                if invalid and (WRINKLED in codes or h < 1e-2):
                    self._end_points = []
                    end = self._range_end(prev, cur, h, failure)
                    if end is not None:
                        pts.extend(self._end_points)  # a pull-in's last tight states (pull_in_end)
                        break
                if h <= cfg.min_step:
                    if invalid:
                        self._end_points = []
                        end = self._range_end(prev, cur, 2 * cfg.min_step, failure)
                        if end is not None:
                            pts.extend(self._end_points)
                    if end is None:
                        notes.append(f"continuation stopped at Φ̂ = {cur.phi:.8g}: {failure.reason[0]} (step {h:.1e})")
                    break
                h *= 0.5
                continue
            edge = self._window_edge(cur, new)
            if edge is not None:
                # the step leaves the voltage window: it ends on the window's edge instead (a step past Φ̂ = 0 had
                # landed on another branch of the mirrored states at Φ̂ < 0, and a 'split' located on that jump
                # ended a stable segment at 0.06 kV ± 0.05 where none is: two bulged zones on a 1e6 ml chamber)
                new = self._at_edge(prev, cur, h, edge)
                if new is cur:  # already on the edge
                    end = self._window_end(edge, cur, cur.stable)
                    break
                if new is None:
                    if h <= cfg.min_step:
                        notes.append(f"continuation stopped at Φ̂ = {cur.phi:.8g}: no state at the window's edge")
                        break
                    h *= 0.5
                    continue
            turn = float(np.arccos(np.clip(new.tangent @ cur.tangent, -1, 1)))
            if turn > cfg.max_turn and h > cfg.min_step:
                h *= 0.5
                continue
            if h > SHORT_STEP and _wrinkled(new) != _wrinkled(cur):
                # a zone group wrinkles (or goes taut again) within the step: cross its onset with a short step, so
                # that the corrector stays on this branch (past a long step it may land on another one: a huge
                # chamber's bulged zone pulls in just past its onset, and a long step had reached a wrinkled state
                # of another branch); the short step then meets the pull-in (a failed state) and ends the segment
                h *= 0.5
                continue
            if h > SHORT_STEP and any(_wrinkled(cur)) and self._hides_invalid(cur, new):
                # a wrinkled band's states can stop being valid inside a step whose ends are both valid (a
                # pressure-controlled zone at 17.8235 mbar: invalid, pulled in, over 2e-3 in Φ̂ within a step of
                # 5e-3, valid again past it): a shorter step meets the invalid states and ends the segment there
                h *= 0.5
                continue
            new.s = cur.s + float(np.linalg.norm(new.z - cur.z))
            found = self._events_between(cur, new)
            if new.stable != cur.stable and not found and h > SHORT_STEP:
                # stability changed within the step, but no event function changed sign: the step is too long to
                # see the event (or it crossed to another branch); a shorter one locates it
                h *= 0.5
                continue
            if h > cfg.min_step and not any(e.kind == "fold" for e in found) and self._hides_folds(cur, new, h):
                # the voltage turns back and forth within the step (two folds, no sign change at its ends): a
                # shorter step meets one fold at a time
                h *= 0.5
                continue
            if any(_wrinkled(cur)) or any(_wrinkled(new)):
                bad = self._past_band_onset(cur, new)
                if bad is not None:
                    # the material's wrinkled stiffness first vanishes inside the step, and a state just past that
                    # voltage is invalid while both ends are valid (a huge chamber's zones: invalid from 3.72295 to
                    # about 3.727 kV, stepped over and listed stable; review, helper-77): the end lies before it. With
                    # an event in the step too, a shorter step separates them (the voltage is monotone along a step
                    # without one, as the probes' placement takes it)
                    end = None if found else self._onset_end(cur, bad)
                    if end is not None:
                        break
                    h *= 0.5
                    continue
            if getattr(self, "stable_only", False):
                stop = [
                    e for e in found if (e.stable_before and not e.stable_after) or e.kind in ("merge", "breakdown")
                ]
                if stop:
                    end = min(stop, key=lambda e: e.s)
                    # a fold and a split at one voltage (identical zones under pressure control: the symmetric and
                    # antisymmetric modes are one dp̂/dV̂ and vanish together) are one event: named the split, as in
                    # the limit of a stiff chamber's gas, where the split comes first (the gas stiffens the symmetric
                    # mode only), whichever rounding located first (it was "fold" at rtol 1e-10 and "split" at 1e-12:
                    # review, helper-73)
                    floor = error_floor(end.phi_hat, self.system.settings.rtol)
                    same = [e for e in stop if abs(e.phi_hat - end.phi_hat) <= e.error + end.error + floor]
                    end = next((e for e in same if e.kind == "split"), end)
                    events.extend(e for e in found if e.s < end.s and not any(e is x for x in same))
                    break
            events.extend(found)
            if edge is not None or not (self.phi_lo <= new.phi <= self.phi_hi):
                if edge is None:
                    edge = self.phi_hi if new.phi > self.phi_hi else self.phi_lo
                end = self._window_end(edge, new, cur.stable)
                pts.append(new)
                break
            pts.append(new)
            prev, cur = cur, new
            h = min(
                cfg.max_step, h * (2.0 if turn < 0.25 * cfg.max_turn else 1.4 if turn < 0.5 * cfg.max_turn else 1.0)
            )
        return pts, events, end, notes

    # events ---------------------------------------------------------------------------------------------
    def _events_between(self, a: Point, b: Point) -> list:
        """Sign changes of the event functions between two points. An event where stability changes, a
        merge or a breakdown is located exactly; the others (on unstable stretches) are recorded where
        the linear interpolation of their function vanishes, marked approximate."""
        va, vb = self.event_values(a), self.event_values(b)
        out = []
        sig_b = float(a.tangent @ (b.z - a.z))
        vfolds = []
        for key, fa in va.items():
            fb = vb[key]
            if not (fa != 0 and np.sign(fa) != np.sign(fb)):
                continue
            kind, _, grp = key.partition(":")
            group = int(grp) if grp else None
            if kind == "volume_fold":
                vfolds.append(group)
            out.append((kind, group, key, fa, fb))
        # the zone's own index first (it decides stability after the step)
        for j in vfolds:
            if j is not None:
                self._update_index(a, b, j)
        precise = a.stable != b.stable
        events = []
        for kind, group, key, fa, fb in out:
            if kind == "breakdown" and fa > 0:
                continue  # coming back below the breakdown field: the membrane is already destroyed
            frac = fa / (fa - fb)
            if precise or kind in ("merge", "breakdown"):
                ev = self._locate(a, b, sig_b, key, fa, fb)
            else:
                ev = None
            if ev is None:
                z = hermite(a.z, a.tangent, b.z, b.tangent, frac)
                ev = Event(
                    kind=key,
                    phi_hat=float(z[self.M] / self.w),
                    eq=(a if frac < 0.5 else b).eq,
                    z=z,
                    s=a.s + frac * (b.s - a.s),
                    error=abs(b.phi - a.phi),
                    note="approximate (not on a stability change)",
                )
            ev.kind, ev.group = kind, group
            ev.stable_before, ev.stable_after = a.stable, b.stable
            events.append(ev)
        return sorted(events, key=lambda e: e.s)

    def _hides_folds(self, a: Point, b: Point, h: float) -> bool:
        """Whether the step ``a -> b`` (of length ``h``) may cross two folds (or a stability change and back)
        that its ends do not show. Only where the Hermite slope of ``wΦ̂`` dips inside the step
        (:func:`_voltage_dip`): a step longer than ``SHORT_STEP`` is then suspect as it is (the unstable piece
        between two close folds can be a tenth of a long step, between any samples); in a shorter one,
        converged points at the dip and at ``DIP_SAMPLES`` of the step (one batched corrector) are examined, and
        the step hides folds when one of them has the fold function of the other sign, or another stability,
        than ``a``. A point that does not converge is no evidence either way."""
        tv = _voltage_dip(a, b, self.M)
        if tv is None:
            return False
        if h > SHORT_STEP:
            return True
        sig_b = float(a.tangent @ (b.z - a.z))
        sigmas = sig_b * np.array(sorted({tv, *DIP_SAMPLES}))
        fa = np.sign(a.tangent[self.M])
        return any(
            p is not None and (np.sign(p.tangent[self.M]) != fa or p.stable != a.stable)
            for p in self._points_at(a, b, sig_b, sigmas, loose=True)
        )

    def _past_band_onset(self, a: Point, b: Point) -> float | None:
        """The offset along ``a``'s tangent of an invalid state just past the voltage ``Φ̂c`` at which the material's
        hoop-wrinkled stiffness first vanishes (:func:`coexist.wrinkling.band_pull_in_onset`), when the step
        ``a -> b`` (both valid) crosses ``Φ̂c``; None otherwise (the usual case: one test of the material per step
        at most, none once the step's voltages are known to lie on one side).

        A state whose wrinkled band spans the first unstable stretch stops being valid at ``Φ̂c`` and can be valid
        again just above (its band moves past the unstable stretches as they widen), so a step can cross the
        invalid states with both ends valid. The states at ``Φ̂c (1 + ε)``, ``ε`` in :data:`ONSET_PROBE_OFFSETS`, on
        the step's Hermite path (one batched corrector) decide. For a patterned zone the layers of its electrode
        regions carry ``Φ̂/n``: the onset is that of the fewest layers, ``n Φ̂c``.

        Parameters
        ----------
        a, b : Point
            The step's ends, both valid, at least one with a wrinkled band.

        Returns
        -------
        float or None
            The offset of the first invalid probe (``self._onset_code`` holds its failure's status code), or None.
        """
        from .wrinkling import band_pull_in_onset, softened_at

        model = self.system.model
        if not model.tension_field:
            return None
        layer = getattr(model, "uniform", model)
        pattern = getattr(model, "pattern", None)
        n = min((r.layers for r in pattern.regions if r.electrode), default=None) if pattern is not None else 1
        if n is None:
            return None
        lo, hi = sorted((a.phi / n, b.phi / n))
        if softened_at(layer, lo) or not (hi > 0 and softened_at(layer, hi)):
            return None
        onset = band_pull_in_onset(layer, max(hi, self.phi_hi / n))
        if onset is None or not lo < onset < hi:
            return None
        sig_b = float(a.tangent @ (b.z - a.z))

        def phi_at(tau):
            return float(hermite(a.z, a.tangent, b.z, b.tangent, tau)[self.M] / self.w) / n

        sigmas = []
        rising = b.phi > a.phi
        for eps in ONSET_PROBE_OFFSETS:
            target = onset * (1 + eps)
            if not lo < target < hi:
                continue
            t0, t1 = 0.0, 1.0
            for _ in range(60):  # monotone along a step without events or hidden folds (checked before this)
                mid = 0.5 * (t0 + t1)
                if (phi_at(mid) < target) == rising:
                    t0 = mid
                else:
                    t1 = mid
            sigmas.append(0.5 * (t0 + t1) * sig_b)
        if not sigmas:
            return None
        order = np.argsort(np.abs(sigmas))
        pts = self._points_at(a, b, sig_b, np.asarray(sigmas)[order], loose=True)
        failed = self._last_failure.failed_states  # per probe of the batch: its invalid state, if it had one
        for i, (k, p) in enumerate(zip(order, pts)):
            code = failed.get(i, (None, None, None))[2]
            if p is None and code is not None:
                self._onset_code = code
                return float(sigmas[k])
        return None

    def _onset_end(self, cur: Point, bad: float) -> Event | None:
        """The range end between ``cur`` and the invalid state at offset ``bad`` found by :meth:`_past_band_onset`:
        bisection on validity (the stiffness that vanishes is inside a band, not at its outer end, so the
        extrapolation of :meth:`pull_in_end` does not apply), or None when it finds no end there."""
        code = self._onset_code  # the invalid probe's own failure (review, helper-80: the first in the batch's dict)
        found = self.validity_bisection(cur, bad, 0.0, float(bad), _validity_tol(code))
        if found is None:
            return None
        best, lo, hi, new_code = found
        code = new_code if new_code is not None else code
        if best is cur or code is None or code == STEP_LIMIT:
            return None
        return self._end_at(best, lo, hi, *failure_reason(code))

    def _hides_invalid(self, a: Point, b: Point) -> bool:
        """Whether the step ``a -> b`` (both valid) crosses states that are not valid: converged points at
        ``DIP_SAMPLES`` of the step (one batched corrector, loose) are examined, and the step hides invalid
        states when the corrector refuses one of them as an invalid state (a pull-in, a wrinkled segment
        without a natural width, ...). A probe that fails otherwise is no evidence either way. The samples
        are a heuristic: an invalid stretch shorter than a quarter of the step can still pass between them.

        Parameters
        ----------
        a, b : Point
            The step's ends, both valid.

        Returns
        -------
        bool
            True when a probe inside the step is an invalid state.
        """
        sig_b = float(a.tangent @ (b.z - a.z))
        self._points_at(a, b, sig_b, sig_b * np.array(DIP_SAMPLES), loose=True)
        return any(c[2] is not None for c in self._last_failure.failed_states.values())

    def _points_at(self, a: Point, b: Point | None, sig_b, sigmas, loose, formal=False, chord=False) -> list:
        """Converged points at arclength offsets ``sigmas`` from ``a`` (one batched corrector); None where
        the corrector fails. ``b`` (or, without it, ``a``'s tangent) gives the predictor; ``chord``: see
        :func:`correct`."""
        sigmas = np.asarray(sigmas, dtype=float)
        if b is not None:
            Z = np.array([hermite(a.z, a.tangent, b.z, b.tangent, s / sig_b if sig_b else 0.5) for s in sigmas])
        else:
            Z = a.z[None, :] + sigmas[:, None] * a.tangent[None, :]
        N = np.repeat(a.tangent[None, :], sigmas.size, axis=0)
        corr = correct(self.system, Z, N, a.tangent @ a.z + sigmas, self.w, loose=loose, formal=formal, chord=chord)
        self._last_failure = corr
        out: list[Point | None] = []
        for i in range(sigmas.size):
            if not corr.ok[i]:
                out.append(None)
                continue
            p = self._point(corr, i, a.tangent, a.index)
            p.s = a.s + float(np.linalg.norm(p.z - a.z))
            out.append(p)
        return out

    def _root(self, a: Point, b: Point | None, sig_b, f_lo, f_hi, fn, formal=False, stop=None):
        """Root of ``fn(point)`` along the branch between ``σ = 0`` (``a``, value ``f_lo``) and ``sig_b``
        (value ``f_hi``): each round evaluates the regula-falsi estimate and two points beside it in one
        corrector call and keeps the smallest bracket with a sign change; loose correctors while the
        bracket is wide, tight ones (the states reported) at the end. Returns ``(point, lo, hi)`` with
        the tightly converged point on the ``a`` side of the final bracket (``a`` itself if none)."""
        orient = np.sign(sig_b) if sig_b else 1.0
        side = np.sign(f_lo)
        # bracket ends as (σ, f, point, loose)
        A = (0.0, float(f_lo), a, False)
        B = (float(sig_b), float(f_hi), b, False)
        tol = self.system.settings.event_tol
        for _ in range(40):
            width = abs(B[0] - A[0])
            if width <= tol or (stop is not None and A[2] is not None and A[2] is not a and stop(A[2])):
                break
            rf = B[0] - B[1] * (B[0] - A[0]) / (B[1] - A[1]) if B[1] != A[1] else 0.5 * (A[0] + B[0])
            lo_s, hi_s = min(A[0], B[0]), max(A[0], B[0])
            if not (lo_s < rf < hi_s):
                rf = 0.5 * (A[0] + B[0])
            d = 0.03 * width
            cands = sorted({x for x in (rf - d, rf, rf + d) if lo_s < x < hi_s}) if d > 0.5 * tol else [rf]
            loose = width > 1e-3
            # in the tight phase the bracket's own ends are converged tightly too (a loose point is off the
            # branch by up to loose_tolerance, which can put it on the wrong side of a close root)
            redo = [] if loose else [e for e in (A, B) if e[3]]
            pts = self._points_at(a, b, sig_b, cands + [e[0] for e in redo], loose, formal)
            for e, p in zip(redo, pts[len(cands) :]):
                fixed = (e[0], float(fn(p)), p, False) if p is not None else None
                if e is A:
                    A = fixed if fixed is not None else A
                else:
                    B = fixed if fixed is not None else B
            pts = pts[: len(cands)]
            nodes = [A] + [(s, float(fn(p)), p, loose) for s, p in zip(cands, pts) if p is not None] + [B]
            if len(nodes) == 2 and not redo:
                break
            nodes.sort(key=lambda x: x[0] * orient)
            for n0, n1 in zip(nodes[:-1], nodes[1:]):
                if n0[1] == 0 or np.sign(n0[1]) != np.sign(n1[1]):
                    A, B = (n0, n1) if np.sign(n0[1]) == side or n0[1] == 0 else (n1, n0)
                    break
            else:
                # no sign change left among the nodes (a re-converged end changed side): keep the end
                # pair that brackets the starting value's opposite sign, widening to a and b
                A = (0.0, float(f_lo), a, False) if np.sign(A[1]) != side else A
                B = (float(sig_b), float(f_hi), b, False) if np.sign(B[1]) == side else B
        best = A[2]
        if best is None or best is a:
            return (a if abs(A[0]) <= tol else None), min(A[0], B[0]), max(A[0], B[0])
        if A[3]:  # converge the bracket's point tightly
            p = self._points_at(a, b, sig_b, [A[0]], False, formal)[0]
            best = p if p is not None else best
        return best, min(A[0], B[0]), max(A[0], B[0])

    def _locate(self, a: Point, b: Point, sig_b, key, fa, fb) -> Event | None:
        """Event ``key`` between ``a`` and ``b``, located on tightly converged states."""
        merge = key.startswith("merge")
        stop = (lambda p: abs(self.event_values(p)[key]) < 1e-4) if merge else None
        best, lo, hi = self._root(a, b, sig_b, fa, fb, lambda p: self.event_values(p)[key], stop=stop)
        if best is None:
            best = a
        if merge:
            return self._merge_point(best, int(key.partition(":")[2]))
        return Event(
            kind=key,
            phi_hat=best.phi,
            eq=best.eq,
            z=best.z,
            s=best.s,
            error=abs(best.tangent[self.M]) * abs(hi - lo) / self.w,
            tangent=best.tangent.copy(),
        )

    def _merge_point(self, near: Point, j: int) -> Event:
        """Where groups ``j`` and ``j + 1`` meet: the symmetric branch point of the coarser configuration
        (its merged group at a pressure extremum, ``dp̂/du = 0``), solved exactly from ``near``."""
        counts = list(self.counts)
        merged_counts = counts[:j] + [counts[j] + counts[j + 1]] + counts[j + 2 :]
        coarse = GroupSystem(
            self.system.model,
            self.system.gas,
            Configuration(tuple(merged_counts)),
            self.system.settings,
            self.system.starts,
        )
        u = list(near.z[: self.M])
        uc = u[:j] + [0.5 * (u[j] + u[j + 1])] + u[j + 2 :]
        bp = symmetric_branch_point(coarse, j, np.array(uc), near.phi)
        eq = bp["eq"]
        z = np.array(list(bp["u"][:j]) + [bp["u"][j]] * 2 + list(bp["u"][j + 1 :]) + [bp["phi"] * self.w])
        return Event(
            kind="merge",
            phi_hat=bp["phi"],
            eq=eq,
            z=z,
            s=near.s,
            group=j,
            error=bp["error"],
            note=f"meets {coarse.configuration.label} at its symmetric branch point",
        )

    def _update_index(self, a: Point, b: Point, j: int):
        """Maddocks' rule at a volume fold of group ``j``: the zone's own index changes by
        ``−sign(dp̂/du · σ)``, ``σ`` the sign of ``dV̂/du`` on the side of smaller ``u`` (``dp̂/du`` taken
        at the point nearer the fold, where it has the sign it has at the fold)."""
        M = self.M
        ua, ub = a.z[j], b.z[j]
        low = a if ua < ub else b
        # dp̂/du at the fold itself (near a spiral's folds its sign can flip within a step)
        fn = lambda p: p.dv_du[j]  # noqa: E731
        at, _, _ = self._root(a, b, float(a.tangent @ (b.z - a.z)), a.dv_du[j], b.dv_du[j], fn)
        near = at if at is not None else (a if abs(a.dv_du[j]) < abs(b.dv_du[j]) else b)
        delta = -int(np.sign(near.dp_du[j] * np.sign(low.dv_du[j])))
        new_index = list(b.index)
        new_index[j] = a.index[j] + (delta if ub > ua else -delta)
        b.index = tuple(max(x, 0) for x in new_index)
        b.stable = _is_stable(b.eq, b.index)
        b.eq.zone_index = tuple(b.index[k] for k in np.argsort(b.z[:M], kind="stable"))

    @staticmethod
    def _window_end(edge: float, pt: Point, stable: bool) -> Event:
        """The event that ends a branch at the window's ``edge``, with the state ``pt`` there."""
        return Event(
            kind="window",
            phi_hat=edge,
            eq=pt.eq,
            z=pt.z,
            s=pt.s,
            stable_before=stable,
            stable_after=stable,
            note="the voltage leaves the window asked for",
        )

    def _window_edge(self, cur: Point, new: Point) -> float | None:
        """The edge of the voltage window that the step ``cur -> new`` crosses (``cur`` inside it or on it, ``new``
        beyond it), or None."""
        if new.phi < self.phi_lo <= cur.phi:
            return self.phi_lo
        if new.phi > self.phi_hi >= cur.phi:
            return self.phi_hi
        return None

    def _at_edge(self, prev, cur: Point, h: float, edge: float) -> Point | None:
        """The branch's state at the window's ``edge`` (a loose solve at that voltage from the predictor that
        reaches it; ``cur`` itself when it lies on the edge already), or None where it fails or the predictor
        does not reach the edge (a fold there)."""
        if cur.phi == edge:
            return cur
        rate = float(cur.tangent[self.M])
        if rate == 0.0:
            return None
        reach = (edge * self.w - float(cur.z[self.M])) / rate
        if not 0.0 < reach <= h:
            return None
        guess = np.array(self._predict(prev, cur, reach), dtype=float)
        # on the edge from the start: the corrector takes a guess whose first step is below its tolerance as it is
        # (review, helper-81: a point 8e-9 in Φ̂ short of the edge, outside the window)
        guess[self.M] = edge * self.w
        normal = np.zeros(self.M + 1)
        normal[self.M] = 1.0
        return self._solve(guess, normal, edge * self.w, cur.tangent, cur.index, loose=True)

    def _predict(self, prev, cur, h):
        """The predictor at arclength ``h`` beyond ``cur``: cubic Hermite extrapolation through the last two
        points (their tangents included) when the step is not much longer than the last one, else the
        tangent."""
        if prev is None:
            return cur.z + h * cur.tangent
        L = float(np.linalg.norm(cur.z - prev.z))
        if L <= 0 or h > 2 * L:
            return cur.z + h * cur.tangent
        return hermite(prev.z, prev.tangent, cur.z, cur.tangent, 1.0 + h / L)

    def validity_bisection(self, cur: Point, h, lo: float, hi: float, tol: float | None = None):
        """Where the states stop being valid along ``cur``'s tangent between the offsets ``lo`` (valid, or ``cur``
        itself at 0) and ``hi`` (not): :data:`RANGE_END_PROBES` points per round in one batched corrector, until
        the bracket is below ``event_tol`` (near an end whose states become singular, as at a pull-in, every
        round counts).

        A probe whose integration runs out of steps (``STEP_LIMIT``) is neither valid nor an end: near a pole
        whose tension falls to zero the states need ever more steps, and a valid state may lie beyond one that
        ran out. Such probes are passed over: the bracket's upper end is the first probe that fails for a
        physical reason, its lower end the last valid probe below that, and the search stops once a round
        narrows neither (every probe inside ran out of steps; the bracket then spans them, and the end's error
        with it). When no probe fails for a physical reason and some ran out of steps, the code is
        ``STEP_LIMIT`` (the caller may raise the budget: :meth:`_budget_end`).

        Parameters
        ----------
        cur : Point
            The point the offsets are measured from (along its tangent).
        h : float
            The predictor's reference step (for :meth:`_points_at`).
        lo, hi : float
            The bracket: arclength offsets of a valid point (or 0) and of an invalid one.
        tol : float, optional
            Bracket width to stop at (default ``event_tol``).

        Returns
        -------
        tuple or None
            ``(best, lo, hi, code)``: the last valid point (``cur`` if none beyond it), the final bracket and
            the failure code met; None when the corrector fails on a valid state, or when ``hi`` is no tight
            probe's failure (a loose probe's, or the caller's) and its state, solved again tightly from ``best``,
            converges (that failure was the corrector's): undecided.
        """
        best, code, confirmed = cur, None, False
        out_of_steps: list[float] = []  # offsets of the probes that ran out of integration steps
        tol = self.system.settings.event_tol if tol is None else max(tol, self.system.settings.event_tol)
        base = lo  # the offset of ``best``: each round predicts from the last valid point, so that the
        # predictor's error shrinks with the bracket and no Newton iterate is carried past the end (where
        # it would refuse a point that converges inside)
        while hi - lo > tol:
            steps = (hi - lo) * np.arange(1, RANGE_END_PROBES + 1) / (RANGE_END_PROBES + 1) + (lo - base)
            loose = (hi - lo) > 1e-4
            pts = self._points_at(best, None, h, steps, loose)
            failed = self._last_failure
            entries = failed.failed_states if hasattr(failed, "failed_states") else {}
            valid = [p is not None and p.tangent @ best.tangent > 0 for p in pts]
            mids = base + steps
            # the first probe that is neither valid nor out of steps decides the round
            codes = [_code_of(p, entries.get(k)) for k, p in enumerate(pts)]
            j = next((k for k in range(RANGE_END_PROBES) if not valid[k] and codes[k] != STEP_LIMIT), None)
            below = [k for k in range(RANGE_END_PROBES if j is None else j) if valid[k]]
            if j is not None and pts[j] is None and codes[j] is None:
                return None  # the corrector failed on a valid state: undecided
            out_of_steps += [float(mids[k]) for k in range(RANGE_END_PROBES) if codes[k] == STEP_LIMIT]
            if below:
                k = below[-1]
                lo, best, base = float(mids[k]), pts[k], float(mids[k])
            if j is not None:
                confirmed = not loose
                hi = float(mids[j])
                code = codes[j] if codes[j] is not None else code
            elif not below:
                break  # every probe inside ran out of steps: at this budget the bracket narrows no further
        if code is None and any(o > lo for o in out_of_steps):
            # probes beyond the last valid one ran out of steps, and none failed physically: the budget decides
            code = STEP_LIMIT
        if not confirmed:
            # no tight probe failed: the bracket closed on a failure of a loose probe or on the caller's ``hi`` (a
            # continuation step's, from its own predictor), whose Newton iterates may have crossed the end from a
            # predictor that overshoots the curving branch (an inner-circle zone of the tricircle scene, 0.84 of
            # its radius: a loose probe 2e-5 before its pull-in failed so, and the end had been put there).
            # Solved again, tightly, from the nearest valid state: converging, it is no end
            p = self._points_at(best, None, h, [hi - base], False)[0]
            if p is not None and p.tangent @ best.tangent > 0:
                return None
        return best, lo, hi, code

    def pull_in_end(self, cur: Point, h, lo: float, hi: float, end_guess: float | None = None):
        """Where a wrinkled band reaches its pull-in, between the offsets ``lo`` (valid, or ``cur`` itself at 0)
        and ``hi`` (not) along ``cur``'s tangent, by extrapolating a smooth function of the valid states.

        At the pull-in of a hoop-wrinkled band the meridian's stiffness along the natural width,
        ``K = dT̂1ʷ/dλ1``, reaches zero where the band ends (``λ1`` falls along the band, towards the minimum of
        ``T̂1ʷ``; docs/physics.md, section 10). Its value there relative to ``T̂11`` (each state's
        ``wrinkled_stiffness``) is a smooth function of the states that falls to zero at the end, but there
        are no states beyond it to bracket the root with: it is extrapolated from the valid side. A round of
        :data:`RANGE_END_PROBES` states locates the end within ``(lo, hi)``; then rounds of three tightly
        converged states at ``σ* − δ, σ* − 2δ, σ* − 3δ`` (``δ`` a quarter of the distance from the last
        state to the estimate ``σ*``) give the next ``σ*`` by the quadratic through them, whose error falls
        like ``δ³`` (about 64 times per round), until two estimates agree to :data:`PULL_IN_SETTLED`. The
        end's voltage comes from the same quadratic extrapolation of the states' ``z``; its error is the
        last change (an overestimate: the last estimate is better than the one before by about that factor).

        Parameters
        ----------
        cur : Point
            The last valid point (offsets are measured along its tangent).
        h : float
            The predictor's reference step.
        lo, hi : float
            The bracket: offsets of a valid point (or 0) and of an invalid one.
        end_guess : float, optional
            An estimate of the end's offset (a located end, re-located at a tighter tolerance): the first
            round is then three tight states below it instead of the bracketing round.

        Returns
        -------
        tuple or None
            ``(best, z_end, error, lo, hi, near)``: the valid state nearest the end, the extrapolated ``z`` of the
            end, the error of its offset (arclength), the final validity bracket (``hi`` infinite when valid
            states beyond the given ``hi`` disproved it and no probe failed beyond them) and the tight states of the
            extrapolation beyond ``cur`` in order (the branch's last points: states asked for between them and
            the end start from them, not from a predictor across the whole last step); None where the states
            carry no wrinkled stiffness or the extrapolation does not settle inside the bracket (the caller
            then bisects on validity).
        """
        from dataclasses import replace

        def stiffness(p):
            values = getattr(p.eq, "wrinkled_stiffness", ())
            return min(values) if values else np.inf

        samples = []  # (offset, stiffness, z) of valid states with a wrinkled band
        if lo == 0.0 and np.isfinite(stiffness(cur)):
            samples.append((0.0, stiffness(cur), cur.z, cur))
        best, best_offset = cur, 0.0
        if end_guess is None:
            offsets = lo + (hi - lo) * np.arange(1, RANGE_END_PROBES + 1) / (RANGE_END_PROBES + 1)
        else:
            offsets = lo + (float(end_guess) - lo) * np.array([0.25, 0.5, 0.75])
        star = None
        rough: list = []  # (offset, stiffness) of loosely converged states
        # a converged valid state proves that the end lies beyond it; a failed probe only suggests that it
        # lies before: its Newton iterates may have crossed the end from a predictor that overshoots the
        # curving branch (a 3000 ml chamber's bulged zone: a loose probe 4e-5 before the end failed so, and
        # the end had been put there). The bracket's ``hi`` is the nearest failure beyond every valid state
        # (``hi`` as given when there is none), and a failure that bounds the extrapolated end is checked
        # once more from the nearest valid state (below). The given ``hi`` is such a failure too (the
        # continuation step that failed there, from its own predictor): a valid state beyond it disproves it,
        # and then only the probes' own failures bound the end (an inner-circle zone of the tricircle scene,
        # 0.84 of its radius: the step failed 2e-5 before the end, the extrapolation's states went past it and
        # were refused, and the end had been put at the failed step)
        hi_given, failures = float(hi), []
        rechecked = False
        for _round in range(PULL_IN_ROUNDS):
            # predicted from the valid state nearest the end, on the hyperplanes of cur's tangent (one
            # parametrisation for every round: offset o is t·(z − z_cur) = o)
            frame = replace(best, tangent=cur.tangent)
            # the first round only brackets the end (loose states while the bracket is wide, as the validity
            # bisection's); the extrapolation's states are tight
            loose = _round == 0 and end_guess is None and hi - lo > 1e-4
            pts = self._points_at(frame, None, h, offsets - best_offset, loose, chord=True)
            for o, p in zip(offsets, pts):
                if p is None or not p.tangent @ cur.tangent > 0:
                    failures.append(float(o))
                    continue
                if o > lo:
                    lo = float(o)
                if o > best_offset:
                    best, best_offset = p, float(o)
                g = stiffness(p)
                if np.isfinite(g) and g > 0 and not loose:
                    samples.append((float(o), g, p.z, p))
                elif np.isfinite(g) and g > 0:
                    rough.append((float(o), g))
            if lo >= hi_given:
                hi_given = np.inf  # a converged valid state beyond the given hi: it was no end
            hi = min([f for f in failures if f > lo], default=hi_given)
            samples = sorted((x for x in samples if x[0] <= lo), key=lambda x: x[0])
            if len(samples) < 3:
                # too few tight states to extrapolate from: the next round's three, placed just below the end
                # estimated from the rough (loose) ones by their secant (the last eighth of the way there:
                # close enough for the first quadratic to be good to ~1e-8), or in the bracket's upper half
                pairs = sorted([(x[0], x[1]) for x in samples] + rough)[-2:]
                if len(pairs) == 2 and pairs[1][1] < pairs[0][1]:
                    (s0, g0), (s1, g1) = pairs
                    guess = min(hi, s1 + g1 * (s1 - s0) / (g0 - g1))
                    offsets = guess - (guess - lo) / 8 * np.array([3.0, 2.0, 1.0])
                elif np.isfinite(hi):
                    offsets = lo + (hi - lo) * np.array([0.25, 0.5, 0.75])
                else:
                    return None  # no bracket and no secant to place the next states by
                continue
            sig = np.array([x[0] for x in samples[-3:]])
            gs = np.array([x[1] for x in samples[-3:]])
            roots = np.roots(np.polyfit(sig, gs, 2))
            roots = roots[np.isreal(roots)].real
            roots = roots[roots > sig[-1]]
            if not roots.size:
                return None
            new = float(roots.min())
            if not new <= hi + (hi - lo):
                # the extrapolated end lies well beyond a failed probe (or the given hi): solve that point again,
                # tightly, from the nearest valid state (a short predictor); still failing, it is not this kind of
                # end
                if rechecked:
                    return None
                rechecked = True
                p = self._points_at(replace(best, tangent=cur.tangent), None, h, [hi - best_offset], False)[0]
                g = stiffness(p) if p is not None and p.tangent @ cur.tangent > 0 else -np.inf
                if not (np.isfinite(g) and g > 0):
                    return None
                if hi in failures:
                    failures.remove(hi)
                if hi >= hi_given:
                    hi_given = np.inf
                lo, best, best_offset = hi, p, hi
                samples.append((hi, g, p.z, p))
                hi = min([f for f in failures if f > lo], default=hi_given)
                offsets = new - 0.25 * (new - lo) * np.array([3.0, 2.0, 1.0])
                continue
            change = abs(new - star) if star is not None else np.inf
            star = new
            if change <= PULL_IN_SETTLED:
                break
            delta = 0.25 * (star - sig[-1])
            offsets = star - delta * np.array([3.0, 2.0, 1.0])
        else:
            if star is None:
                return None
            change = abs(star - samples[-1][0])
        sig = np.array([x[0] for x in samples[-3:]])
        zs = np.array([x[2] for x in samples[-3:]])
        coef = np.polyfit(sig, zs, 2)
        z_end = coef[0] * star**2 + coef[1] * star + coef[2]
        # the state kept as the end's (the transition's state before it) gets its own slopes; the others are only
        # the branch's last points, whose slopes (those of an earlier iterate, within 1e-4) serve as predictors
        near = [x[3] for x in samples if x[0] > 0]
        if near:
            near[-1] = self._with_fresh_slopes([near[-1]], cur)[0]
        return (near[-1] if near else samples[-1][3]), z_end, float(change), lo, hi, near

    def _with_fresh_slopes(self, points: list, cur: Point) -> list:
        """``points`` (converged by chord steps: their slopes are those of an earlier iterate) evaluated once more
        at their own ``z`` with derivatives, in one batch: their tangents, ``dp̂/dV̂``, eigenvalues and stability are
        then those of the states themselves (a point whose evaluation fails is kept as it was)."""
        if not points:
            return points
        Z = np.array([p.z for p in points])
        N = np.repeat(cur.tangent[None, :], len(points), axis=0)
        corr = correct(self.system, Z, N, Z @ cur.tangent, self.w)
        out = []
        for i, p in enumerate(points):
            if corr.ok[i]:
                q = self._point(corr, i, cur.tangent, p.index)
                q.s = p.s
                out.append(q)
            else:
                out.append(p)
        return out

    @property
    def tight_rtol(self) -> float:
        """``rtol/100`` (at least ``RTOL_MIN``): the tolerance at which this tracer's doubtful decisions are
        checked."""
        from .settings import RTOL_MIN

        return max(self.system.settings.rtol / 100, RTOL_MIN)

    def with_settings(self, settings) -> Tracer:
        """The same tracer (configuration, window, breakdown, step budget of reference) with other solver
        settings.

        Parameters
        ----------
        settings : SolverSettings
            The settings of the new tracer's system.

        Returns
        -------
        Tracer
            A tracer of the same configuration whose system has ``settings``.
        """
        system = GroupSystem(
            self.system.model, self.system.gas, self.system.configuration, settings, self.system.starts
        )
        out = Tracer(system, (self.phi_lo, self.phi_hi), self.breakdown)
        out.stable_only = getattr(self, "stable_only", False)
        out.base_steps = self.base_steps
        return out

    def with_budget(self, max_steps: int) -> Tracer:
        """The same tracer with another integration step budget (``SolverSettings.max_steps``).

        Parameters
        ----------
        max_steps : int
            The budget per trajectory.

        Returns
        -------
        Tracer
            A tracer of the same configuration, window and breakdown, whose settings differ in ``max_steps``
            only (every state that integrates within both budgets is the same state).
        """
        from dataclasses import replace

        return self.with_settings(replace(self.system.settings, max_steps=int(max_steps)))

    def _budget_end(self, prev, cur: Point, h, phi_fail: float) -> Event:
        """The end of a branch whose states stopped at ``phi_fail`` because their integration used up its step
        budget: the same step again with :data:`BUDGET_ESCALATION` times the budget, up to
        :data:`BUDGET_ESCALATION_MAX` times the settings' own.

        Near some ends the meridian's integration takes ever more steps as the end is approached (a pole whose
        tension falls to zero: the pole of a nearly slack zone), so a fixed budget runs out just before the
        physical end. Where a probe beyond those that ran out of steps fails for a physical reason, the validity
        bisection brackets the end without this (:meth:`validity_bisection`); this is for a bracket in which every
        failure was the budget. Where a larger budget reaches a physical end (any failure but the budget) it is that
        end, located as usual by the tracer with the larger budget, which the event records (``max_steps``: its
        re-location uses it too).

        Parameters
        ----------
        prev, cur : Point
            The last two points of the branch (``cur`` valid).
        h : float
            The step from ``cur`` that failed.
        phi_fail : float
            Where the states were seen to stop (for the message).

        Returns
        -------
        Event
            The physical end (``range_end``).

        Raises
        ------
        SolverError
            If the states go on with a larger budget (the continuation at the settings' budget cannot follow
            them), or still run out of steps at the largest budget: a numerical failure, never a transition.
        """
        settings = self.system.settings
        base = self.base_steps
        where = f"the states of {self.system.configuration.label} at Φ̂ = {phi_fail:.10g}"
        if settings.max_steps * BUDGET_ESCALATION > base * BUDGET_ESCALATION_MAX:
            raise SolverError(
                f"{where} stop: their integration used up its step budget (SolverSettings.max_steps = "
                f"{settings.max_steps}, {settings.max_steps // base} times the settings' {base}) without reaching "
                "a physical end"
            )
        big = self.with_budget(settings.max_steps * BUDGET_ESCALATION)
        new = big._solve(
            self._predict(prev, cur, h), cur.tangent, cur.tangent @ cur.z + h, cur.tangent, cur.index, loose=True
        )
        failure = getattr(big, "_last_failure", None)
        codes = [c[2] for c in getattr(failure, "failed_states", {}).values() if c[2] is not None]
        end = None
        if new is None and codes:
            big._end_points = []
            end = big._range_end(prev, cur, h, failure)
        if end is None:
            raise SolverError(
                f"{where} stop: their integration used up its step budget (SolverSettings.max_steps = "
                f"{settings.max_steps}); with {big.system.settings.max_steps} steps they go on: raise "
                "SolverSettings.max_steps"
            )
        if end.max_steps is None:
            end.max_steps = big.system.settings.max_steps
        self._end_points = big._end_points
        return end

    def _formal_onset(self, cur: Point, h):
        """The onset of wrinkling within the step ``h`` beyond ``cur`` (taut): the root of the smallest tension
        ``T̂min(σ)`` of formally continued states (:func:`coexist.shooting.solve_states`, ``formal``), smooth
        through zero, bracketed from ``cur`` (``T̂min > 0``) and a formal state at ``σ ≤ h`` (``T̂min < 0``; the
        offset is halved, up to 8 times, where that state does not converge).

        Returns
        -------
        tuple or None
            ``(best, lo, hi)`` as :meth:`_root`: the tight state on the taut side of the final bracket and its
            offsets; None where the formal states do not wrinkle within the step or the root is not bracketed.
        """
        tmin = lambda p: min(p.eq.min_tension)  # noqa: E731
        sig = float(h)
        for _ in range(8):
            far = self._points_at(cur, None, sig, [sig], True, formal=True)[0]
            if far is None:
                sig *= 0.5
                continue
            if tmin(far) >= 0:
                return None  # valid there after all: the step failed for another reason
            best, lo, hi = self._root(
                cur, far, float(cur.tangent @ (far.z - cur.z)), tmin(cur), tmin(far), tmin, formal=True
            )
            if best is None or tmin(best) < 0:
                return None
            return best, lo, hi
        return None

    def _range_end(self, prev, cur: Point, h, failure):
        """Locate where the states stop being valid between ``cur`` (valid) and ``cur + h t`` (not), or
        return None when the failure was the corrector's (the caller then shortens the step).

        Wrinkling: the smallest tension of formally continued states (:func:`coexist.shooting.solve_states`,
        ``formal``) is a smooth function through zero, and its root is found like any event. Any other
        failure (the chains lock, no clamp is reached): bisection on validity, where a corrector that
        fails without an invalid state stops the search (undecided).
        """
        codes = [c[2] for c in failure.failed_states.values() if c[2] is not None]
        if not codes:
            return None
        code = codes[0]
        onset = None
        if code != WRINKLED and self.system.model.tension_field and not any(_wrinkled(cur)):
            # a taut tension-field branch that ends within the step: where the formally continued taut states
            # wrinkle inside it and the states just past that onset are no continuation of the branch, the end
            # is the onset itself (the wrinkled side's stiffness is negative there: _WRINKLE_PULL_IN)
            onset = self._formal_onset(cur, h)
            if onset is not None:
                # states past the onset (one within the bracket's tolerance of it may converge taut, its smallest
                # tension of the order of rtol: no evidence) continue the branch when they carry a band; the band's
                # own pull-in may come soon after the onset (5 V after it in the default scene, where a loose
                # tolerance's long step probed only 1/8 of the way and took the onset for the end: review,
                # helper-73), so they are probed at 8⁻¹ … 8⁻⁶ of the rest of the step
                past = [onset[2]] + [onset[2] + (float(h) - onset[2]) / 8.0**k for k in range(1, ONSET_PROBES + 1)]

                def banded(tracer):
                    return any(
                        p is not None and p.tangent @ cur.tangent > 0 and any(_wrinkled(p))
                        for p in tracer._points_at(cur, None, h, past, False)
                    )

                # a band found by states at rtol/100 counts too: a loose tolerance's taut states can step over the
                # hoop tension's narrow dip where the band starts (the default scene at rtol 1e-7: taut with
                # T̂min = 0.118 where the formally continued states and those at 1e-9 carry a band, so the onset
                # was taken for the end, 5 V before the band's pull-in: review, helper-73)
                if banded(self) or banded(self.with_settings(self.system.settings.with_rtol(self.tight_rtol))):
                    onset = None  # the tension-field states go on past the onset: not this end
        if code == WRINKLED or onset is not None:
            found = onset if onset is not None else self._formal_onset(cur, h)
            if found is None:
                return None
            best, lo, hi = found
            return self._end_at(best, lo, hi, *(failure_reason(WRINKLED) if onset is None else _WRINKLE_PULL_IN))
        else:
            if _is_pull_in(code):
                # a wrinkled band's pull-in: a smooth function of the states falls to zero there
                ext = self.pull_in_end(cur, h, 0.0, float(h))
                if ext is not None:
                    best, z_end, err, lo, hi, self._end_points = ext
                    tag, text = failure_reason(code)
                    return Event(
                        kind="range_end",
                        phi_hat=float(z_end[self.M] / self.w),
                        eq=best.eq,
                        z=z_end,
                        s=best.s + float(np.linalg.norm(z_end - best.z)),
                        error=abs(best.tangent[self.M]) * err / self.w,
                        note=f"{tag}: {text}",
                        stable_before=best.stable,
                        stable_after=False,
                        tangent=best.tangent.copy(),
                    )
            # bisection on validity, RANGE_END_PROBES points per round in one batched corrector (the bracket
            # shrinks by that plus one per round: a third of the rounds of plain bisection, each a little
            # dearer; near an end whose states become singular, as at a pull-in, every round counts)
            found = self.validity_bisection(cur, h, 0.0, float(h), _validity_tol(code))
            if found is None:
                return None
            best, lo, hi, new_code = found
            code = new_code if new_code is not None else code
            if code == STEP_LIMIT:
                # the states stop because their integration runs out of steps: no physical end
                return self._budget_end(prev, cur, h, best.phi)
            if best is cur:
                return None
        return self._end_at(best, lo, hi, *failure_reason(code))

    def _end_at(self, best: Point, lo: float, hi: float, tag: str, text: str) -> Event:
        """The range end at the last valid point ``best`` of the bracket ``(lo, hi)`` (arclength offsets), its
        error the bracket's width in voltage ``|dΦ̂/ds| (hi − lo)``, its note ``"tag: text"``."""
        return Event(
            kind="range_end",
            phi_hat=best.phi,
            eq=best.eq,
            z=best.z,
            s=best.s,
            error=abs(best.tangent[self.M]) * abs(hi - lo) / self.w,
            note=f"{tag}: {text}",
            stable_before=best.stable,
            stable_after=False,
            tangent=best.tangent.copy(),
        )


#: factor by which :meth:`Tracer._budget_end` raises the integration step budget at an end where the states
#: ran out of steps with no probe beyond them failing for a physical reason (:meth:`Tracer.validity_bisection`), and
#: the largest multiple of the settings' budget it goes to (heuristic)
BUDGET_ESCALATION = 4
BUDGET_ESCALATION_MAX = 64
#: points per round of the bisection that locates where the states stop being valid
RANGE_END_PROBES = 7
#: rounds of the pull-in extrapolation (:meth:`Tracer.pull_in_end`) before it gives up
PULL_IN_ROUNDS = 6
#: where a pull-in end falls back to bisection on validity, it counts as located when the bracket (arclength) is this
#: narrow (its states approach a singular meridian: every round counts)
PULL_IN_BRACKET = 1e-7
#: a pull-in end (arclength) counts as located when two extrapolations agree to this (:meth:`Tracer.pull_in_end`;
#: the error then left is about 64 times smaller, and the change is what the end reports). At 1e-7 the default
#: scene's pull-in printed ± 2.2e-8 kV where an independent calculation differs by 3e-10 kV
#: (tests/test_transition_variations.py); one more round costs three tight states (no measurable time) and leaves
#: ± 4.6e-9 kV, 4e-11 kV from it
PULL_IN_SETTLED = 1e-9


def _code_of(point, entry) -> int | None:
    """The failure code of a probe of :meth:`Tracer._points_at` (None for a converged point, or a corrector that
    failed without an invalid state); ``entry`` is its item of the corrector's ``failed_states``."""
    if point is not None or entry is None:
        return None
    return entry[2]


def _is_pull_in(code_or_note) -> bool:
    """Is an end of this kind (a failure code, or an event's note) the pull-in of a wrinkled band?"""
    from .shooting import PULL_IN

    if isinstance(code_or_note, (int, np.integer)):  # any code, -1 (outside the physical range) included
        return int(code_or_note) == PULL_IN
    return str(code_or_note).startswith("electromechanical_instability: a wrinkled")


def _note_reason(note: str) -> tuple:
    """``(tag, sentence)`` of a range end's note (``"tag: sentence"``, as :func:`failure_reason` gives)."""
    tag, _, text = note.partition(": ")
    return tag, text


def _is_formal_end(note: str) -> bool:
    """Is a range end of this note the onset of wrinkling between pole and clamp (located as the root of the
    formally continued states' smallest tension, not by validity)?"""
    return _note_reason(note) in (tuple(failure_reason(WRINKLED)), _WRINKLE_PULL_IN)


#: states past a taut branch's onset of wrinkling probed for a continuing band (:meth:`Tracer._range_end`): at
#: ``8⁻ᵏ`` of the rest of the failing step, ``k = 1 … ONSET_PROBES``
ONSET_PROBES = 6

#: the reason of a tension-field branch's end at the onset of wrinkling (:meth:`Tracer._range_end`): the taut
#: states wrinkle there (located as the root of the formally continued states' smallest tension) and no
#: tension-field state continues the branch past it. Where the hoop tension ``T̂2`` first vanishes the band would
#: start at its natural width ``λ2*(λ1) = ρ``; with a positive wrinkled stiffness ``K = T̂11 − T̂12²/T̂22`` there the
#: relaxed equations continue the taut states with a growing band, so a branch that stops is one whose ``K`` is
#: negative at the band's start: the band is past its pull-in as it forms (a ring electrode's side of its inner
#: edge, whose ``λ1`` jumps past the maximum of ``T̂1ʷ``: ``K = −1.85`` in one zone of ring 0.4/0.9 at 6.365 kV,
#: ``−2.25`` for ring 0.2/0.8 at 4.040 kV; tests/test_patterned_tf_ends.py)
_WRINKLE_PULL_IN = (
    "wrinkling_pull_in",
    "a hoop tension reaches zero and the membrane wrinkles, and no tension-field state continues the branch: "
    "the band would start past its pull-in (dT1/dλ1 along its natural width negative where it forms)",
)


def _validity_tol(code_or_note) -> float | None:
    """The validity bisection's bracket for an end of this kind (a failure code, or an event's note)."""
    return PULL_IN_BRACKET if _is_pull_in(code_or_note) else None


def relocate(event: Event, tracer: Tracer, tight: Tracer) -> float:
    """Locate ``event`` again with the tighter tracer ``tight`` (same configuration, a smaller ``rtol``)
    and return the change of its voltage: the measured error of the event at ``tracer``'s tolerance.
    ``event.error`` becomes twice that change plus the location bracket and :func:`error_floor`, and
    ``event.measured`` True.

    A ``merge`` is solved again as the coarser configuration's symmetric branch point; any other event
    is bracketed by two tight states at ``±δ`` (``δ`` = 1e-5, 1e-4, 1e-3 in turn) along its tangent and
    located by one secant step.

    Parameters
    ----------
    event : Event
        The event, as located by ``tracer``; updated in place.
    tracer : Tracer
        The tracer that located it (its ``rtol`` sets the error floor).
    tight : Tracer
        The same configuration at the tighter tolerance.

    Returns
    -------
    float
        The change of the event's voltage ``Φ̂``. When the event cannot be located again (no tangent, or
        no sign change at any ``δ``), ``event.error`` is returned instead and ``event`` is left unchanged.

    Raises
    ------
    SolverError
        If a ``merge``'s symmetric branch point does not converge.
    """
    M = tracer.M
    if event.max_steps is not None and event.max_steps > tight.system.settings.max_steps:
        tight = tight.with_budget(event.max_steps)  # its states needed that budget (Tracer._budget_end)
    if event.kind == "merge":
        j = event.group or 0
        counts = list(tracer.counts)
        coarse_counts = counts[:j] + [counts[j] + counts[j + 1]] + counts[j + 2 :]
        coarse = GroupSystem(
            tight.system.model,
            tight.system.gas,
            Configuration(tuple(coarse_counts)),
            tight.system.settings,
            tight.system.starts,
        )
        u = list(event.z[:M])
        uc = u[:j] + [u[j]] + u[j + 2 :]
        bp = symmetric_branch_point(coarse, j, np.array(uc), event.phi_hat)
        change = abs(bp["phi"] - event.phi_hat)
    elif event.tangent is None:
        return event.error
    elif event.kind == "range_end" and not _is_formal_end(event.note):
        # an end without a smooth event function (Gent locking, pull-in, a pole that wrinkles, no equilibrium):
        # the same validity bisection with the tight tracer, in a bracket of ±δ around the loose end, which must
        # end on a state of the same failure (one that runs out of integration steps first gets a larger budget,
        # as the loose end did: Tracer._budget_end); a pull-in is extrapolated again from the tight states on the
        # valid side
        change = None
        base = Point(event.z.copy(), event.tangent, event.eq, np.zeros(M), np.zeros(M), (0,) * M, True)
        for delta in (1e-5, 1e-4, 1e-3):
            pts = tight._points_at(base, None, 0.0, [-delta, delta], False)
            start = -delta  # the offset of the valid side's state from the loose end
            if pts[0] is None and not _is_pull_in(event.note):
                # the tangent's predictor back along a branch that curves into its end can fail (a pole whose
                # tension falls to zero): the loose end's own state, converged tightly, is the valid side
                pts[0], start = tight._points_at(base, None, 0.0, [0.0], False)[0], 0.0
            beyond = pts[1] is None or not pts[1].tangent @ event.tangent > 0
            if pts[0] is None or not beyond:
                continue
            if _is_pull_in(event.note):
                ext = tight.pull_in_end(pts[0], 2 * delta, 0.0, 2 * delta, end_guess=delta)
                if ext is not None:
                    best, z_end, err, _, _, _ = ext
                    change = abs(float(z_end[M]) / tight.w - event.phi_hat) + abs(best.tangent[M]) * err / tight.w
                    break
            # offsets from the valid side's tight state (validity_bisection measures them from its ``cur``, at 0)
            span = delta - start
            found = tight.validity_bisection(pts[0], span, 0.0, span, _validity_tol(event.note))
            while (
                found is not None
                and found[3] == STEP_LIMIT
                and tight.system.settings.max_steps * BUDGET_ESCALATION <= BUDGET_ESCALATION_MAX * tight.base_steps
            ):
                tight = tight.with_budget(tight.system.settings.max_steps * BUDGET_ESCALATION)
                found = tight.validity_bisection(pts[0], span, 0.0, span, _validity_tol(event.note))
            if found is None or (found[3] is not None and failure_reason(found[3]) != _note_reason(event.note)):
                continue  # undecided, or another end than the loose one's
            best, lo, hi, _ = found
            change = abs(best.phi - event.phi_hat) + abs(best.tangent[M]) * abs(hi - lo) / tight.w
            break
        if change is None:
            return event.error
    else:
        key = event.kind if event.group is None else f"{event.kind}:{event.group}"
        t = event.tangent
        change = None
        for delta in (1e-5, 1e-4, 1e-3):
            base = Point(event.z.copy(), t, event.eq, np.zeros(M), np.zeros(M), (0,) * M, True)
            pts = tight._points_at(base, None, 0.0, [-delta, delta], False, formal=(event.kind == "range_end"))
            if any(p is None for p in pts):
                continue
            if event.kind == "range_end":
                fa, fb = (min(p.eq.min_tension) for p in pts)
                fn = lambda p: min(p.eq.min_tension)  # noqa: E731
            else:
                fa, fb = (tight.event_values(p)[key] for p in pts)
                fn = lambda p: tight.event_values(p)[key]  # noqa: E731
            if np.sign(fa) == np.sign(fb):
                continue
            # the tight event lies within a few rtol of the loose one: one secant step from ±delta, checked
            # by one more tight state (whose own event function bounds what the secant left)
            s_star = -delta + 2 * delta * fa / (fa - fb)
            p = tight._points_at(base, None, 0.0, [s_star], False, formal=(event.kind == "range_end"))[0]
            if p is None:
                continue
            f_star = fn(p)
            slope = (fb - fa) / (2 * delta)
            left = abs(f_star / slope) if slope != 0 else 2 * delta
            change = abs(p.phi - event.phi_hat) + abs(p.tangent[M]) * left / tight.w
            break
        if change is None:
            return event.error
    # twice the change: the tighter value carries noise of its own (near the shooting's noise floor an
    # event located at rtol/100 is not a hundred times better)
    event.error = float(event.error + 2 * change + error_floor(event.phi_hat, tracer.system.settings.rtol))
    event.measured = True
    return change


def error_floor(phi: float, rtol: float) -> float:
    """The smallest error a located voltage is given: ``10 rtol |Φ̂|`` (its states and their convergence
    are no better than the tolerance, whatever the re-location says).

    Parameters
    ----------
    phi : float
        The located voltage ``Φ̂``.
    rtol : float
        The shooting's relative tolerance.

    Returns
    -------
    float
        ``10 rtol |Φ̂|``.
    """
    return 10 * rtol * abs(phi)


def _is_stable(eq: Equilibrium, index) -> bool:
    return bool(eq.min_eigenvalue > 0 and all(x == 0 for x in index))


def symmetric_branch_point(system: GroupSystem, j: int, u_guess, phi_guess, max_iter: int = 30) -> dict:
    """The state where group ``j`` (of two or more zones) of ``system`` sits at a pressure extremum
    (``dp̂/du = 0``) while in equilibrium: there its zones can move against each other at no cost and the
    configurations that split it leave the branch.

    Newton's method on ``[r(u, Φ̂) = 0, dp̂/du(uj, Φ̂) = 0]``; the first rows' Jacobian is exact, the last
    row's (``d²p̂/du²``, ``∂²p̂/∂u∂Φ̂``) is a central difference of the exact first derivatives (its error
    only slows the convergence, not the solution). Returns the state (``eq``), ``u``, ``phi`` and the
    last Newton step in ``Φ̂`` as ``error``.

    Parameters
    ----------
    system : GroupSystem
        The coarser configuration, in which group ``j`` holds the zones that split.
    j : int
        The group (``nj ≥ 2``).
    u_guess : array_like, shape (M,)
        First guess of the groups' ``u``.
    phi_guess : float
        First guess of ``Φ̂``.
    max_iter : int, optional
        Newton iterations (default 30).

    Returns
    -------
    dict
        ``eq`` (:class:`~coexist.equilibria.Equilibrium`), ``u`` (ndarray, shape (M,)), ``phi`` (float) and
        ``error`` (float, ``|last Newton step in Φ̂|``).

    Raises
    ------
    SolverError
        If a state on the way is invalid, or Newton's method does not converge in ``max_iter`` steps.
    """
    M = system.groups
    u = np.array(u_guess, dtype=float)
    phi = float(phi_guess)
    tol = system.settings.newton_tol
    step_phi = np.inf
    prev = np.inf
    for _ in range(max_iter):
        hu = 1e-5 * max(u[j], 1e-3)
        hp = 1e-5 * max(abs(phi), 1e-2)
        U = np.tile(u, (5, 1))
        Ph = np.full(5, phi)
        U[1, j] += hu
        U[2, j] -= hu
        Ph[3] += hp
        Ph[4] -= hp
        res = system.residual(U, Ph)
        if not res.states.ok.all():
            bad = res.states.status[~res.states.ok][0]
            code = int(bad[bad != 0][0])
            raise SolverError(
                f"symmetric branch point of {system.configuration.label}: {failure_reason(code)[1]} near Φ̂ = {phi:.8g}"
            )
        dp = res.states.dp_du[:, j]
        F = np.concatenate([res.r[0], [dp[0]]])
        A = np.zeros((M + 1, M + 1))
        A[:M] = res.J[0]
        A[M, j] = (dp[1] - dp[2]) / (2 * hu)
        A[M, M] = (dp[3] - dp[4]) / (2 * hp)
        step = np.linalg.solve(A, -F)
        size = float(np.max(np.abs(step)))
        if size <= tol or (size >= 0.5 * prev and size <= 1e3 * tol):
            from .equilibria import make_equilibrium as _mk

            eq = _mk(system, res, 0)
            return {"eq": eq, "u": u.copy(), "phi": phi, "error": abs(float(step[M]))}
        prev = size
        step_phi = float(step[M])
        u = u + step[:M]
        phi = phi + step_phi
    raise SolverError(f"symmetric branch point of {system.configuration.label} did not converge near Φ̂ = {phi:.8g}")


# --- the stable equilibria of a scene over a voltage window ------------------------------------------
class StableSegment:
    """A stable piece of a configuration's branch (a branch traced with ``stable_only``), a graph over
    ``Φ̂`` (a fold would end it): its points, and the events that end it at low and high voltage."""

    def __init__(self, branch: Branch, tracer: Tracer, branches=None):
        self.branch = branch
        self.tracer = tracer
        self.branches = branches  # per group (ordered by pole stretch), the piece of the zone curve it is on
        pts = branch.points
        self.points = pts
        rising = pts[-1].phi >= pts[0].phi
        lo_end, hi_end = branch.ends
        self.low, self.high = (lo_end, hi_end) if rising else (hi_end, lo_end)
        self._phi = np.array([p.phi for p in pts])
        self._order = np.argsort(self._phi)

    @property
    def configuration(self) -> Configuration:
        """The configuration of the segment's states (groups ordered by pole stretch)."""
        return self.points[0].eq.configuration

    @property
    def label(self) -> str:
        """The configuration's name, with the branches of the zone curve where they are not the usual ones
        (:func:`~coexist.equilibria.configuration_label`)."""
        from .equilibria import configuration_label

        return configuration_label(self.configuration, self.branches)

    def end(self, direction: int):
        """The event reached when the voltage moves in ``direction`` (+1 up, −1 down), or None.

        Parameters
        ----------
        direction : int
            ``+1`` (voltage up) or ``−1`` (down).

        Returns
        -------
        Event or None
            The event that ends the segment on that side (None where the trace stopped without one).
        """
        return self.high if direction > 0 else self.low

    def end_phi(self, direction: int) -> float:
        """The voltage ``Φ̂`` at which the segment ends in ``direction``.

        Parameters
        ----------
        direction : int
            ``+1`` (voltage up) or ``−1`` (down).

        Returns
        -------
        float
            The end event's ``Φ̂``; without an event, the largest (smallest) ``Φ̂`` of the segment's points.
        """
        e = self.end(direction)
        if isinstance(e, Event):
            return e.phi_hat
        return self._phi.max() if direction > 0 else self._phi.min()

    @property
    def phi_range(self) -> tuple:
        """``(Φ̂ low end, Φ̂ high end)`` of the segment."""
        return self.end_phi(-1), self.end_phi(+1)

    def contains(self, phi: float, slack: float = 0.0) -> bool:
        """Whether the voltage ``Φ̂`` lies within the segment's range (widened by ``slack`` on both sides).

        Parameters
        ----------
        phi : float
            The voltage ``Φ̂``.
        slack : float, optional
            Widening of the range (default 0).

        Returns
        -------
        bool
            ``lo − slack ≤ Φ̂ ≤ hi + slack``.
        """
        lo, hi = self.phi_range
        return lo - slack <= phi <= hi + slack

    def predict(self, phi: float) -> np.ndarray:
        """A first guess of ``z`` at voltage ``Φ̂`` (cubic Hermite between the two points around it).

        The chord parameter at which the Hermite cubic reaches ``Φ̂`` is found by Newton's method (8
        iterations at most); beyond the end nodes the end piece is extrapolated. The nodes are the segment's
        points and, at an end that is a fold located beyond the last point, the fold's state with its tangent
        (``dΦ̂/ds = 0`` there): between the last point and the fold the branch turns, and the end piece
        extrapolated past the last point would cross the fold onto the unstable side, from where Newton's
        method at fixed voltage, its matrix nearly singular, steps out of the physical range (the tricircle
        with Gent ``Jlim = 300``: 2.22 kV, 5e-4 kV below the fold that ends its bulged segment). On the piece
        that ends at the fold the chord parameter is kept within ``[0, 1]``.

        Parameters
        ----------
        phi : float
            The voltage ``Φ̂``.

        Returns
        -------
        ndarray, shape (M + 1,)
            ``z = (u1 … uM, wΦ̂)``, its voltage entry exactly ``w phi``.
        """
        # nodes (Φ̂, z, tangent) in ascending Φ̂; True marks a fold end
        nodes = [(p.phi, p.z, p.tangent, False) for p in (self.points[i] for i in self._order)]
        for direction in (-1, +1):
            e = self.end(direction)
            edge = nodes[-1 if direction > 0 else 0][0]
            if (
                isinstance(e, Event)
                and e.kind == "fold"
                and e.tangent is not None
                and direction * (e.phi_hat - edge) > 0
            ):
                node = (e.phi_hat, e.z, e.tangent, True)
                nodes = nodes + [node] if direction > 0 else [node] + nodes
        phis = np.array([nd[0] for nd in nodes])
        if phi <= phis[0]:
            k = 0
        elif phi >= phis[-1]:
            k = len(nodes) - 2
        else:
            k = int(np.searchsorted(phis, phi) - 1)
        if len(nodes) == 1:
            z = nodes[0][1].copy()
            z[-1] = phi * self.tracer.w
            return z
        (a_phi, a_z, a_t, a_fold), (b_phi, b_z, b_t, b_fold) = nodes[k], nodes[k + 1]
        ta = a_t if (b_z - a_z) @ a_t >= 0 else -a_t
        tb = b_t if (b_z - a_z) @ b_t >= 0 else -b_t
        frac = (phi - a_phi) / (b_phi - a_phi) if b_phi != a_phi else 0.0
        frac = float(np.clip(frac, -0.5, 1.5))

        def voltage_gap(x, _):  # Φ̂ along the Hermite curve minus the target, and its slope (forward difference)
            z0, z1 = hermite(a_z, ta, b_z, tb, float(x[0])), hermite(a_z, ta, b_z, tb, float(x[0]) + 1e-6)
            return np.array([z0[-1] / self.tracer.w - phi]), np.array([(z1[-1] - z0[-1]) / self.tracer.w / 1e-6])

        lo = hi = None
        if (a_fold or b_fold) and a_phi <= phi <= b_phi:
            # the fold's piece: Φ̂ is stationary at the fold node, a Newton step may leave the piece (bisected)
            frac, lo, hi = float(np.clip(frac, 0.0, 1.0)), 0.0, 1.0
        frac = float(newton(voltage_gap, frac, xtol=1e-12, max_iter=8, stop_when_stalled=False, lo=lo, hi=hi).x[0])
        z = hermite(a_z, ta, b_z, tb, frac)
        z[-1] = phi * self.tracer.w
        return z

    def states(self, phis, coincident: bool = True) -> list:
        """Converged equilibria at the voltages ``phis`` (one batched Newton at fixed voltage).

        Parameters
        ----------
        phis : float or array_like, shape (K,)
            Voltages ``Φ̂`` within the segment.
        coincident : bool, optional
            Where Newton's method fails within a merge end's uncertainty, give the coincident state
            (:meth:`_coincident_state`; default True). False: such a voltage raises like any other (the
            equal-free-energy search, for which the coincident state is the other segment's own state).
            Beyond that uncertainty, next to a symmetric branch point, a failed fixed-voltage Newton is
            followed by the solve parametrised by the split (:meth:`_pitchfork_state`), whatever
            ``coincident`` says (its state is this segment's own).

        Returns
        -------
        list of Equilibrium
            One per voltage, tightly converged from :meth:`predict` (with chord steps), carrying the
            segment's zone index.

        Raises
        ------
        SolverError
            If a state does not converge.
        """
        phis = np.atleast_1d(np.asarray(phis, dtype=float))
        if phis.size == 0:
            return []
        w = self.tracer.w
        M = self.tracer.M
        Z = np.array([self.predict(p) for p in phis])
        n = np.zeros((phis.size, M + 1))
        n[:, M] = 1.0
        corr = correct(self.tracer.system, Z, n, phis * w, w, chord=True)
        out = []
        index = self.points[0].index
        failed = np.flatnonzero(~corr.ok)
        alone: dict = {}
        if failed.size and phis.size > 1:
            # the corrector switches to chord steps for the whole batch at once: a row next to a pitchfork, whose
            # steps stay large, kept a row 1e-8 kV below a fold on full Newton steps, which stop at the shooting's
            # noise there and were taken to diverge (two zones, the path [0, 3.85215522, 4.10604894, 0] kV failed
            # where each voltage alone converged). Each failed row alone first
            for j in failed.tolist():
                one = correct(self.tracer.system, Z[j : j + 1], n[j : j + 1], phis[j : j + 1] * w, w, chord=True)
                if one.ok[0]:
                    alone[j] = make_equilibrium(self.tracer.system, one.res, one.rows[0], index)
            failed = np.array([j for j in failed.tolist() if j not in alone], dtype=int)
        retry = None
        if failed.size:
            # just inside an end at the onset of wrinkling a Newton iterate can step past the onset and be
            # refused; the formally continued equations are smooth there, and a converged state whose
            # tensions are all positive is a taut equilibrium like any other
            retry = correct(self.tracer.system, Z[failed], n[failed], phis[failed] * w, w, chord=True, formal=True)
        for i in range(phis.size):
            if corr.ok[i]:
                out.append(make_equilibrium(self.tracer.system, corr.res, corr.rows[i], index))
                continue
            if i in alone:
                out.append(alone[i])
                continue
            k = int(np.searchsorted(failed, i))
            eq = None
            if retry is not None and retry.ok[k]:
                eq = make_equilibrium(self.tracer.system, retry.res, retry.rows[k], index)
                if not min(eq.min_tension) > 0:
                    eq = None
            if eq is None and coincident:
                eq = self._coincident_state(float(phis[i]), index)
            if eq is None:
                eq = self._pitchfork_state(float(phis[i]), index)
            if eq is None:
                eq = self._fold_state(float(phis[i]))
            if eq is None:
                raise SolverError(
                    f"{self.label}: no converged state at Φ̂ = {phis[i]:.10g} on its stable segment ({corr.reason[i]})"
                )
            out.append(eq)
        return out

    def _coincident_state(self, phi: float, index) -> Equilibrium | None:
        """The state at ``Φ̂`` where it lies at a merge end of the segment within that end's uncertainty:
        the coincident state (the merging groups equal), or None elsewhere.

        At a symmetric branch point (a pitchfork) the segment's groups ``j``, ``j + 1`` meet: with
        ``x = uj − uj+1``, ``Φ̂ − Φ̂bp ≈ c x²`` and the antisymmetric eigenvalue of the Jacobian vanishes like
        ``Φ̂ − Φ̂bp``, so Newton's method at fixed voltage cannot converge there, and within the uncertainty
        ``ε = max(error of the merge, 10 rtol Φ̂bp)`` (:func:`error_floor`) of ``Φ̂bp`` it is not even known
        on which side of the branch point ``Φ̂`` lies. There the coincident state, solved by Newton's method
        at ``Φ̂`` exactly in the coarser configuration (regular there) and evaluated in this one
        (``r(u, Φ̂) = 0`` holds in both), is the segment's state; it differs from the split one by
        ``|x| ≲ (2ε / c)^½``, which the solver's tolerance does not resolve. A note on the state says so.

        Parameters
        ----------
        phi : float
            The voltage ``Φ̂``.
        index : tuple
            The segment's zone index (given to the state).

        Returns
        -------
        Equilibrium or None
            The coincident state, or None when ``Φ̂`` is not within a merge end's uncertainty or the coarse
            Newton does not converge.
        """
        system = self.tracer.system
        M, w = self.tracer.M, self.tracer.w
        for e in (self.low, self.high):
            if not (isinstance(e, Event) and e.kind == "merge" and e.group is not None and e.z is not None):
                continue
            if abs(phi - e.phi_hat) > max(float(e.error), error_floor(e.phi_hat, system.settings.rtol)):
                continue
            j = int(e.group)
            counts = list(system.configuration.counts)
            coarse = GroupSystem(
                system.model,
                system.gas,
                Configuration(tuple(counts[:j] + [counts[j] + counts[j + 1]] + counts[j + 2 :])),
                system.settings,
                system.starts,
            )
            z = np.concatenate([e.z[: j + 1], e.z[j + 2 :]])  # the merged groups once
            z[-1] = phi * w
            n = np.zeros((1, M))
            n[0, M - 1] = 1.0
            corr = correct(coarse, z[None], n, np.array([phi * w]), w)
            if not corr.ok[0]:
                return None
            u = np.insert(corr.z[0, : M - 1], j + 1, corr.z[0, j])
            res = system.residual(u[None], np.array([phi]))
            tol = system.settings.residual_tol * (1 + abs(float(res.gas_pressure[0])))
            if not (res.states.ok.all() and np.max(np.abs(res.r[0])) <= tol):
                return None
            eq = make_equilibrium(system, res, 0, index)
            eq.notes.append(
                f"within {abs(phi - e.phi_hat):.1e} of the symmetric branch point at Φ̂ = {e.phi_hat:.10g} "
                "(inside its uncertainty): the coincident state"
            )
            return eq
        return None

    def _fold_state(self, phi: float) -> Equilibrium | None:
        """The state of a fold end of the segment where ``Φ̂`` lies within that fold's uncertainty (its error, at
        least :func:`error_floor`), or None elsewhere: at a fold the Jacobian at fixed voltage is singular and Newton's
        method there cannot converge, and within the uncertainty it is not known on which side of the fold ``Φ̂``
        lies (a path voltage 4e-11 kV below the fold of two bulged zones on a 1000 l chamber exited 1; review,
        helper-81). The fold's own state, at its voltage, with a note. A split end counts too (called only where
        Newton's method failed): under near pressure control the split of identical zones and the fold of their
        branch are one event, named the split (three Gent 30 zones on a 1e6 ml chamber, the path voltage 6.38 kV
        6.5e-12 in Φ̂ below it, exited 1; a robustness sweep, helper-87)."""
        rtol = self.tracer.system.settings.rtol
        for e in (self.low, self.high):
            if not (isinstance(e, Event) and e.kind in ("fold", "split") and e.eq is not None):
                continue
            if abs(phi - e.phi_hat) > max(float(e.error), error_floor(e.phi_hat, rtol)):
                continue
            eq = copy.deepcopy(e.eq)
            eq.notes.append(
                f"within {abs(phi - e.phi_hat):.1e} of the {e.kind} at Φ̂ = {e.phi_hat:.10g} (inside its uncertainty, "
                f"where Newton's method at fixed voltage cannot converge): the {e.kind}'s own state"
            )
            return eq
        return None

    def _split_residual(self, u, phi: float, j: int):
        """The equilibrium residual at ``(u, Φ̂)`` with the row of groups ``j``, ``j + 1`` (their divided
        difference of ``p̂``) evaluated as the mean of ``dp̂/du`` by 3-point Gauss–Legendre quadrature,

        ``r_{j+1} = [p̂(u_{j+1}) − p̂(u_j)] / x = ∫₀¹ p̂′(u_j + t x) dt ≈ Σₖ wₖ p̂′(m + ξₖ x / 2)``,

        ``m`` the midpoint, ``x = u_{j+1} − u_j``, ``ξ = 0, ±√(3/5)``, ``w = 4/9, 5/18, 5/18`` (error
        ``x⁶ p̂⁽⁷⁾ / 2016000``). Both are the same equation; the divided difference of two pressures of
        order one, each rounded to ``ε |p̂|``, carries ``≈ 10 ε |p̂| / |x|`` (``2e-11 · (1 + |p̂|)`` at
        ``x = 1.5e-5``, the rtol 1e-12 solver tolerance), the quadrature of the exact slopes ``≈ 10 ε``.

        Returns
        -------
        tuple
            ``(r, res)``: the residual (shape ``(M,)``, row ``j + 1`` by quadrature) and the system's own
            :class:`~coexist.equilibria.Residual` at the point (its Jacobian, exact, is used as is), or
            None where a state is invalid.
        """
        system = self.tracer.system
        res = system.residual(u[None], np.array([phi]))
        m, x = 0.5 * (u[j] + u[j + 1]), u[j + 1] - u[j]
        nodes = m + 0.5 * x * np.array([[0.0, -np.sqrt(0.6), np.sqrt(0.6)]])
        st = shoot_groups(system.model, nodes, np.array([phi]), system.settings, starts=system.starts)
        if not (res.states.ok.all() and st.ok.all()):
            return None
        r = res.r[0].copy()
        r[j + 1] = float(st.dp_du[0] @ np.array([4 / 9, 5 / 18, 5 / 18]))
        return r, res

    def _pitchfork_state(self, phi: float, index) -> Equilibrium | None:
        """The state at ``Φ̂`` next to a symmetric branch point that ends the segment, beyond that point's
        uncertainty, solved with the split as the parameter; None where no such end is next to ``Φ̂``.

        At a pitchfork (groups ``j``, ``j + 1`` of equal counts merge at ``Φ̂bp``) the split branch is
        ``Φ̂ − Φ̂bp ≈ c x²``, ``x = |u_{j+1} − u_j|``; Newton's method at fixed ``Φ̂`` is singular there (the
        antisymmetric eigenvalue vanishes like ``Φ̂ − Φ̂bp``). At fixed ``x`` the equations
        ``r(u, Φ̂) = 0`` in the unknowns (the other ``u``, ``Φ̂``), with ``u_{j+1} = u_j ± x``, are regular
        (the branch point's own extended system at ``x = 0``); their solution ``Φ̂(x)`` is smooth and even
        in ``x``, so ``Φ̂(√s) − Φ̂target`` is a regular 1-D root in ``s = x²``, bracketed by the branch point
        (``s = 0``, ``Φ̂bp``) and the segment's point nearest it, found by the Illinois method. The row of
        the two groups is evaluated by quadrature (:meth:`_split_residual`: the divided difference of the
        pressures is rounding at ``x ~ 1e-5``). The final state is shot at exactly ``Φ̂target`` and must
        have every residual below ``residual_tol (1 + |p̂|)`` and be stable; its ``residual`` is the largest of
        them (the pair's row by quadrature: the divided difference's own is its rounding, ``≈ 10 ε |p̂| / x``).
        Its note gives ``x``.

        Parameters
        ----------
        phi : float
            The voltage ``Φ̂``.
        index : tuple
            The segment's zone index (given to the state).

        Returns
        -------
        Equilibrium or None
            The split state, or None where ``Φ̂`` is not between a pitchfork end (beyond its uncertainty)
            and the segment's point nearest it, or a solve fails (the caller then raises).
        """
        system = self.tracer.system
        settings = system.settings
        counts = system.configuration.counts
        for e in (self.low, self.high):
            if not (isinstance(e, Event) and e.kind == "merge" and e.group is not None and e.z is not None):
                continue
            j = int(e.group)
            if counts[j] != counts[j + 1]:
                continue  # not a symmetric pitchfork (Φ̂ − Φ̂bp is then linear in x)
            if abs(phi - e.phi_hat) <= max(float(e.error), error_floor(e.phi_hat, settings.rtol)):
                continue  # inside the branch point's uncertainty: which side is unknown
            near = min(self.points, key=lambda p: abs(p.phi - e.phi_hat))
            if not (
                (phi - e.phi_hat) * (near.phi - e.phi_hat) > 0 and abs(phi - e.phi_hat) < abs(near.phi - e.phi_hat)
            ):
                continue  # not between the branch point and the segment's point nearest it
            return self._split_state(e, near, phi, index)
        return None

    def _split_state(self, e: Event, near: Point, phi: float, index) -> Equilibrium | None:
        """The solve of :meth:`_pitchfork_state` for the merge end ``e``, bracketed by it and the point
        ``near``: the split state at ``Φ̂ = phi``, or None where a solve fails or the state is not converged
        or not stable."""
        system = self.tracer.system
        settings = system.settings
        M = self.tracer.M
        j = int(e.group)  # type: ignore[arg-type]  # a merge end has its group
        x_near = float(near.z[j + 1] - near.z[j])
        sign = 1.0 if x_near > 0 else -1.0  # the segment's orientation
        free = [i for i in range(M) if i != j + 1]
        guess_u, guess_phi = np.array(e.z[:M], dtype=float), float(e.phi_hat)

        def at_split(x: float):
            """Newton's method at fixed split ``x`` in (the other ``u``, ``Φ̂``): ``(u, Φ̂, r, res)`` or None."""
            nonlocal guess_u, guess_phi
            u, ph = guess_u.copy(), guess_phi
            prev = np.inf
            for it in range(settings.max_newton):
                u[j + 1] = u[j] + sign * x
                out = self._split_residual(u, ph, j)
                if out is None:
                    return None
                r, res = out
                J = res.J[0]
                A = np.concatenate([J[:, free], J[:, M : M + 1]], axis=1)
                A[:, j] += J[:, j + 1]  # u_{j+1} moves with u_j
                try:
                    step = np.linalg.solve(A, -r)
                except np.linalg.LinAlgError:
                    return None
                size = float(np.max(np.abs(step)))
                small_r = np.max(np.abs(r)) <= settings.residual_tol * (1 + abs(float(res.gas_pressure[0])))
                if (size <= settings.newton_tol and small_r) or (
                    it >= 2 and size >= 0.5 * prev and size <= 1e3 * settings.newton_tol
                ):
                    guess_u, guess_phi = u.copy(), ph  # the next solve starts here
                    return u, ph, r, res
                if it >= 2 and size > 2 * prev:
                    return None
                prev = size
                u[free] += step[: M - 1]
                ph += float(step[M - 1])
            return None

        class _Failed(Exception):
            pass

        def gap(s, _):
            x = float(np.sqrt(s[0]))
            if x <= 10 * settings.merge_tolerance:  # the system's residual merges the groups below it
                raise _Failed
            sol = at_split(x)
            if sol is None:
                raise _Failed
            return np.array([sol[1] - phi])

        try:
            root = bracketed_root(
                gap,
                0.0,
                x_near**2,
                e.phi_hat - phi,
                near.phi - phi,
                ftol=1e-3 * settings.residual_tol,  # Φ̂(s) this close to the target: shot at the target below
                max_iter=60,
            )
        except _Failed:
            return None
        if not root.converged[0]:
            return None
        x = float(np.sqrt(root.x[0]))
        sol = at_split(x)
        if sol is None:
            return None
        out = self._split_residual(sol[0], phi, j)  # exactly at the target voltage
        if out is None:
            return None
        r, res = out
        tol = settings.residual_tol * (1 + abs(float(res.gas_pressure[0])))
        if not np.max(np.abs(r)) <= tol:
            return None
        eq = make_equilibrium(system, res, 0, index)
        if not _is_stable(eq, eq.zone_index):
            return None
        eq.residual = float(np.max(np.abs(r)))
        eq.notes.append(
            f"{abs(phi - e.phi_hat):.1e} from the symmetric branch point at Φ̂ = {e.phi_hat:.10g}: solved "
            f"with the split |Δu| = {x:.6e} as the parameter (fixed-voltage Newton is singular there)"
        )
        return eq

    def matches(self, eq: Equilibrium, tol: float = 1e-6) -> bool:
        """Is ``eq`` (a stable equilibrium) the state of this segment at its voltage? The segment's state
        there is converged (loosely) from its interpolation and compared with ``eq``.

        Parameters
        ----------
        eq : Equilibrium
            The state.
        tol : float, optional
            Largest difference in ``u`` of the sorted groups (at least ``10 · loose_tolerance``; default 1e-6).

        Returns
        -------
        bool
            True when the configurations agree, ``Φ̂`` lies in the segment's range and the groups' ``u``
            agree within the tolerance.
        """
        if eq.configuration.counts != self.configuration.counts or not self.contains(eq.phi_hat, 1e-12):
            return False
        M = self.tracer.M
        corr = solve_at_voltage(self.tracer, self.predict(eq.phi_hat), eq.phi_hat, loose=True)
        if not corr.ok[0]:
            return False
        u = np.sort(corr.z[0, :M])
        u_eq = np.sort(np.sqrt(np.asarray(eq.pole_stretch) - self.tracer.system.model.prestretch))
        return bool(np.max(np.abs(u - u_eq)) <= max(tol, 10 * self.tracer.system.settings.loose_tolerance))


class EquilibriumMap:
    """The stable equilibria of ``N`` identical zones on a gas over a voltage window, traced on demand.

    One object per scene (and gas): the ramp, the coexistence table and the fit all read its
    segments, so they agree by construction. Segments are traced when first asked for (a ramp
    traces only the configurations its path visits), so the cost does not grow with ``N``.

    Parameters
    ----------
    model : MembraneModel
    gas : GasChamber or PressureReservoir
    zones : int
    settings : SolverSettings
    phi_window : (float, float)
        Voltages of interest; segments are traced up to its edges.
    breakdown : Breakdown or None
        A segment ends where the largest field reaches the breakdown field (:class:`~coexist.effects.Breakdown`).
    """

    def __init__(self, model, gas, zones: int, settings, phi_window, breakdown: Breakdown | None = None):
        self.model, self.gas, self.zones, self.settings = model, gas, int(zones), settings
        self.phi_window = (float(phi_window[0]), float(phi_window[1]))
        self.breakdown = breakdown
        self.segments: list[StableSegment] = []
        self._tracers: dict = {}
        # the converged states of a patterned zone, shared by every configuration's system: each starts the
        # interface-scale iteration of the states shot near it (coexist.patterned.ScaleStarts; a start only)
        self._starts = scale_starts(model)

    def tracer(self, counts) -> Tracer:
        """The tracer of the configuration ``counts`` (made once, then kept).

        Parameters
        ----------
        counts : sequence of int
            Group sizes ``(n1 … nM)``.

        Returns
        -------
        Tracer
            Over the map's voltage window, with its breakdown.
        """
        counts = tuple(int(c) for c in counts)
        if counts not in self._tracers:
            system = GroupSystem(self.model, self.gas, Configuration(counts), self.settings, self._starts)
            self._tracers[counts] = Tracer(system, self.phi_window, self.breakdown)
        return self._tracers[counts]

    def find(self, eq: Equilibrium) -> StableSegment | None:
        """The segment already traced that holds ``eq`` (:meth:`StableSegment.matches`), or None.

        Parameters
        ----------
        eq : Equilibrium
            A stable equilibrium.

        Returns
        -------
        StableSegment or None
            The first matching segment.
        """
        for seg in self.segments:
            if seg.matches(eq):
                return seg
        return None

    def segment_of(self, eq: Equilibrium, index=None) -> StableSegment:
        """The stable segment through the stable equilibrium ``eq`` (traced if new).

        Parameters
        ----------
        eq : Equilibrium
            A stable equilibrium of the map's zones and gas.
        index : sequence of int, optional
            Each group's zone index, in ``eq``'s group order (default all 0).

        Returns
        -------
        StableSegment
            The known segment that matches ``eq``, or a new one, seeded at ``eq`` and traced with
            ``stable_only`` (then added to :attr:`segments`).

        Raises
        ------
        SolverError
            If the seed does not converge, or the converged seed is not stable.
        """
        seg = self.find(eq)
        if seg is not None:
            return seg
        counts = eq.configuration.counts
        tr = self.tracer(counts)
        u = np.sqrt(np.asarray(eq.pole_stretch) - self.model.prestretch)
        seed = tr.seed(np.concatenate([u, [eq.phi_hat * tr.w]]), index)
        if not seed.stable:
            raise SolverError(f"{eq.label} at Φ̂ = {eq.phi_hat:.8g} is not stable: no stable segment through it")
        seg = StableSegment(tr.trace(seed, stable_only=True), tr, self.branches_of(seed.eq))
        self.segments.append(seg)
        return seg

    def branches_of(self, eq: Equilibrium) -> tuple:
        """Per group of ``eq`` (ordered by pole stretch), the piece of the zone curve it is on.

        Parameters
        ----------
        eq : Equilibrium
            The state.

        Returns
        -------
        tuple of int
            :func:`~coexist.equilibria.pressure_branch` of each group (0: first rising branch).
        """
        from .equilibria import pressure_branch

        pre = self.model.prestretch
        return tuple(
            pressure_branch(self.model, np.sqrt(lam - pre), eq.phi_hat, self.settings) for lam in eq.pole_stretch
        )
