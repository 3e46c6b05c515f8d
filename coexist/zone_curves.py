"""A smooth representation of one zone's curve at fixed voltage, and its branches.

The shooting solver gives exact states at chosen pole stretches; the coexistence and N-zone
solvers need ``p̂, V̂, Ψ̂, Q̂`` as smooth functions of the pole stretch with derivatives. A
:class:`ZoneCurve` holds cubic splines (not-a-knot) through states on a pole-stretch grid. Its
interpolation error is measured against fresh shooting at the grid mid-points
(:meth:`ZoneCurve.interpolation_error`), so every number derived from it can carry that error.

Branches: the curve is cut into pieces on which ``p̂`` is monotone in ``λ0``; pieces past a volume
fold (``dV̂/dλ0 < 0``) are unstable even under volume control and are marked unusable.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .errors import ModelRangeError
from .model import MembraneModel
from .numerics.roots import bracketed_root
from .numerics.sets import unique_sorted
from .numerics.splines import interpolating_cubics
from .settings import SolverSettings
from .shooting import first_valid_run, reason_tag, reason_text, solve_states


@dataclass(frozen=True)
class Branch:
    """A piece of the curve on which ``p̂(λ0)`` is monotone.

    ``rising`` means ``dp̂/dV̂ > 0`` (stable under pressure control); ``usable`` is False past a
    volume fold, where a zone is unstable even when its volume is held.

    Attributes
    ----------
    index : int
        Position along the curve (0 at the flat end).
    start, stop : float
        Ends of the piece in ``u = √(λ0 − λpre)`` (grid ends, pressure extrema or volume folds).
    rising, usable : bool
        As above.
    p_range : tuple of float
        ``(smallest, largest)`` ``p̂`` on the piece (its values at the ends).
    """

    index: int
    start: float
    stop: float
    rising: bool
    usable: bool
    p_range: tuple


class ZoneCurve:
    """``p̂, V̂, Ψ̂, Q̂`` of one clamped zone at fixed ``Φ̂`` as splines in the pole stretch.

    The splines are in ``u = √(λ0 − λpre)``, in which the states are smooth down to the flat
    membrane (the apex deflection ``δ ∝ u``, so ``V̂ ∝ u`` and ``p̂ ∝ u³`` there), whereas in ``λ0``
    they have a square-root singularity at ``λ0 = λpre``. All methods take and return ``u``;
    :meth:`to_u` and :meth:`to_stretch` convert.

    Parameters
    ----------
    pole_stretch : ndarray
        Increasing grid on which the states are valid.
    p_hat, v_hat, psi_hat, q_hat : ndarray
        States on the grid.
    phi_hat : float
        The fixed normalised voltage ``Φ̂``.
    stopped_because : str, optional
        Why the valid range ends before the requested one.
    prestretch : float
        ``λpre`` of the model, the origin of ``u``.

    Raises
    ------
    ModelRangeError
        With fewer than 5 grid points (reason ``no_equilibrium``).
    """

    def __init__(self, pole_stretch, p_hat, v_hat, psi_hat, q_hat, phi_hat, stopped_because=None, prestretch=1.0):
        self.prestretch = float(prestretch)
        l0 = np.asarray(pole_stretch, dtype=float)
        x = self.to_u(l0)
        if x.size < 5:
            raise ModelRangeError(f"fewer than 5 valid states at Φ̂ = {phi_hat:.6g}: no usable curve", "no_equilibrium")
        self.phi_hat = float(phi_hat)
        self.grid = x
        self.pole_stretch = l0
        # not-a-knot spline coefficients are linear in the data: one basis per grid, reused by every
        # curve on that grid (the voltage family shares its grid), then one product per quantity
        self.p, self.v, self.psi = interpolating_cubics(x, np.column_stack([p_hat, v_hat, psi_hat]))
        self._q_values = np.asarray(q_hat, dtype=float)
        self._q = None
        self.dp = self.p.derivative()
        self.dv = self.v.derivative()
        self.stopped_because = stopped_because
        self._branch_list = None

    @property
    def q(self):
        """Spline of ``Q̂`` (built on first use: most solvers never need the charge)."""
        if self._q is None:
            (self._q,) = interpolating_cubics(self.grid, self._q_values[:, None])
        return self._q

    def to_u(self, pole_stretch):
        """``u = √(λ0 − λpre)``.

        Parameters
        ----------
        pole_stretch : float or array_like
            Pole stretch ``λ0 ≥ λpre``.

        Returns
        -------
        ndarray
            ``u``, shaped like the input.
        """
        return np.sqrt(np.asarray(pole_stretch, dtype=float) - self.prestretch)

    def to_stretch(self, u):
        """``λ0 = λpre + u²``.

        Parameters
        ----------
        u : float or array_like
            The curve parameter ``u``.

        Returns
        -------
        ndarray
            Pole stretch ``λ0``, shaped like the input.
        """
        return self.prestretch + np.asarray(u, dtype=float) ** 2

    @classmethod
    def from_states(cls, states, phi_hat, prestretch=1.0):
        """The first contiguous valid run of ``states`` (a :class:`MembraneStates` on a grid).

        Parameters
        ----------
        states : MembraneStates
            States at one voltage on an increasing pole-stretch grid.
        phi_hat : float
            Their voltage ``Φ̂``.
        prestretch : float
            ``λpre`` of the model.

        Returns
        -------
        ZoneCurve
            Splines through the run; ``stopped_because`` names the failure that ends it, if any.

        Raises
        ------
        ModelRangeError
            If no state is valid (reason: that of the first state) or the run has fewer than 5.
        """
        ok = states.ok
        if not ok.any():
            code = states.status[0]
            raise ModelRangeError(f"no valid state at Φ̂ = {phi_hat:.6g}: {reason_text(code)}", reason_tag(code))
        sl = first_valid_run(ok)
        last = sl.stop - 1
        stopped = None
        if last + 1 < ok.size:
            code = states.status[last + 1]
            stopped = f"{reason_tag(code)} beyond pole stretch {states.pole_stretch[last]:.6g}"
        return cls(
            states.pole_stretch[sl],
            states.p_hat[sl],
            states.v_hat[sl],
            states.psi_hat[sl],
            states.q_hat[sl],
            phi_hat,
            stopped,
            prestretch,
        )

    @classmethod
    def compute(
        cls,
        model: MembraneModel,
        phi_hat: float,
        pole_stretch,
        settings: SolverSettings | None = None,
        stop_at_jumps: bool = False,
    ):
        """Shoot the states on ``pole_stretch`` and build the curve.

        Parameters
        ----------
        model : MembraneModel
            The membrane.
        phi_hat : float
            Normalised voltage ``Φ̂``.
        pole_stretch : array_like
            Increasing pole stretches ``λ0 > λpre``.
        settings : SolverSettings, optional
            Shooting tolerances.
        stop_at_jumps : bool, optional
            End the curve where its states jump (:func:`_wrinkling_jump`: the wrinkled fraction changes
            discontinuously in ``λ0``, so the pole stretch does not parametrise the family there and a spline
            through the jump is meaningless); ``stopped_because`` then names the jump. Default False (the
            states past the jump are kept: each is a valid state).

        Returns
        -------
        ZoneCurve
            As :meth:`from_states`; where the valid run ends at a failed state inside the grid, the end is
            narrowed between the last valid and the first failed grid point (:func:`_refined_end`) and the
            curve reaches the last valid state found there.

        Raises
        ------
        SceneError
            For invalid pole stretches (fewer than 3, not increasing, not above ``λpre``) or voltage
            (:func:`~coexist.shooting.solve_states`).
        ModelRangeError
            If fewer than 5 consecutive states are valid.
        """
        from .curves import _check_range

        # an unsorted or repeated grid made splines of divided-by-zero slopes and false reasons (review, helper-62)
        pole_stretch = _check_range(pole_stretch, model)
        states = _refined_end(model, solve_states(model, pole_stretch, phi_hat, settings), phi_hat, settings)
        if stop_at_jumps:
            cut = _wrinkling_jump(model, states, phi_hat, settings)
            if cut is not None:
                kept, why = cut
                curve = cls.from_states(kept, phi_hat, model.prestretch)
                curve.stopped_because = why
                return curve
        return cls.from_states(states, phi_hat, model.prestretch)

    @property
    def span(self):
        """``(u_first, u_last)``: the ends of the grid."""
        return float(self.grid[0]), float(self.grid[-1])

    def _critical(self, spline):
        """Interior roots of a spline's derivative (sorted)."""
        roots = spline.derivative().roots(extrapolate=False)
        lo, hi = self.span
        return np.sort(roots[(roots > lo) & (roots < hi)])

    @property
    def branches(self) -> list:
        """Monotone pieces of the curve (built on first use: following a state does not need them)."""
        if self._branch_list is None:
            self._branch_list = self._branches()
        return self._branch_list

    def _branches(self):
        lo, hi = self.span
        p_turn = self._critical(self.p)
        v_turn = self._critical(self.v)
        cuts = unique_sorted(np.concatenate([[lo], p_turn, v_turn, [hi]]))
        out = []
        for i, (a, b) in enumerate(zip(cuts[:-1], cuts[1:])):
            mid = 0.5 * (a + b)
            rising_p = self.dp(mid) > 0
            vol_ok = self.dv(mid) > 0
            pa, pb = float(self.p(a)), float(self.p(b))
            out.append(
                Branch(i, float(a), float(b), bool(rising_p == vol_ok), bool(vol_ok), (min(pa, pb), max(pa, pb)))
            )
        return out

    def pressure_extrema(self):
        """Pole stretches of the pressure maxima and minima (spline roots of ``dp̂/dλ0``), as ``u``.

        Returns
        -------
        ndarray
            The interior roots of ``dp̂/du`` in ``u = √(λ0 − λpre)`` (:meth:`to_stretch` converts),
            sorted; maxima and minima alternate.
        """
        return self._critical(self.p)

    def stretch_at_pressure(self, branch: Branch, p_hat):
        """The ``u`` on ``branch`` where ``p̂(u) = p_hat`` (a float, or an array for an array of pressures): the
        spline inverted by :func:`~coexist.numerics.roots.bracketed_root`, all pressures at once.

        Parameters
        ----------
        branch : Branch
            A monotone piece of this curve (:attr:`branches`).
        p_hat : float or array_like
            Normalised pressure(s) ``p̂`` within the branch's ``p_range``.

        Returns
        -------
        float or ndarray
            ``u`` on the branch, to 1e-14.

        Raises
        ------
        ValueError
            If a pressure lies outside the branch's range.
        """
        P = np.atleast_1d(np.asarray(p_hat, dtype=float))
        fa, fb = float(self.p(branch.start)) - P, float(self.p(branch.stop)) - P
        if np.any(fa * fb > 0):
            raise ValueError("pressure outside the branch")
        root = bracketed_root(
            lambda x, idx: self.p(x) - P[idx],
            branch.start,
            np.full(P.size, branch.stop),
            fa,
            fb,
            xtol=1e-14,
            rtol=1e-15,
        )
        return float(root.x[0]) if np.ndim(p_hat) == 0 else root.x

    def interpolation_error(self, model: MembraneModel, settings: SolverSettings | None = None) -> dict:
        """Largest error of the splines at the grid mid-points against fresh shooting, relative to
        the largest magnitude of each quantity along the curve.

        Parameters
        ----------
        model : MembraneModel
            The model the curve was shot with.
        settings : SolverSettings, optional
            Shooting tolerances for the mid-points.

        Returns
        -------
        dict
            ``{"p_hat", "v_hat", "psi_hat"}`` to the relative error (NaN if no mid-point state is
            valid; mid-points with a failed state are skipped).
        """
        mids = 0.5 * (self.grid[1:] + self.grid[:-1])
        s = solve_states(model, self.to_stretch(mids), self.phi_hat, settings)
        ok = s.ok
        err = {}
        for name, spline, exact in (
            ("p_hat", self.p, s.p_hat),
            ("v_hat", self.v, s.v_hat),
            ("psi_hat", self.psi, s.psi_hat),
        ):
            e = np.abs(spline(mids[ok]) - exact[ok]) / max(float(np.max(np.abs(exact[ok]), initial=0.0)), 1e-300)
            err[name] = float(e.max()) if e.size else float("nan")
        return err


#: rounds of sampling that narrow the end of a zone curve's valid run (:func:`_refined_end`), and points per round
END_ROUNDS = 3
END_SAMPLES = 8


def _refined_end(model, states, phi_hat, settings):
    """``states`` on a grid with the end of their first valid run narrowed: where the run stops at a failed state
    (wrinkling, pull-in, ...) inside the grid, :data:`END_ROUNDS` rounds of :data:`END_SAMPLES` states evenly
    between the last valid and the first failed pole stretch (one batch a round) move the bracket to the first
    failure among them; the valid states below it are inserted into the run (so the curve reaches within
    ``(9)⁻³`` of a grid spacing of where its states end, and an equilibrium there can be found from it: a bulged
    zone's state between the last valid grid point and the pull-in that ends the curve was missed). States after
    the first valid run are kept as they are (they decide nothing)."""
    ok = states.ok
    if not ok.any():
        return states
    run = first_valid_run(ok)
    last = run.stop - 1
    if run.stop >= ok.size:
        return states
    from .curves import _take

    a, b = float(states.pole_stretch[last]), float(states.pole_stretch[last + 1])
    extra = []
    for _ in range(END_ROUNDS):
        pts = np.linspace(a, b, END_SAMPLES + 2)[1:-1]
        st = solve_states(model, pts, phi_hat, settings)
        bad = np.flatnonzero(~st.ok)
        k = int(bad[0]) if bad.size else pts.size
        if k > 0:
            extra.append((pts[:k], st, k))
            a = float(pts[k - 1])
        if k < pts.size:
            b = float(pts[k])
    if not extra:
        return states
    parts = [_take(states, slice(0, last + 1))]
    parts += [_take(st, slice(0, k)) for _, st, k in extra]
    parts.append(_take(states, slice(last + 1, None)))
    return _concatenate(parts)


#: heuristic threshold: a change of the wrinkled fraction (reference area fraction of the zone) between neighbouring
#: states that, narrowed by :data:`END_ROUNDS` rounds of :data:`END_SAMPLES` states to ``(9)⁻³`` of a grid spacing,
#: still exceeds it is a jump of the family (a continuous onset changes it by ``O(Δλ0)`` there)
WRINKLE_JUMP = 0.05


@dataclass
class _JumpCandidate:
    """A pair of neighbouring grid states whose wrinkled fractions differ by more than :data:`WRINKLE_JUMP`, as
    :func:`_wrinkling_jump` narrows it: grid index of its lower state, the bracket ``(a, wa)``–``(b, wb)`` in
    ``(λ0, w)``, the narrowing's valid states below the jump, and whether it still is one."""

    index: int
    a: float
    wa: float
    b: float
    wb: float
    extra: list = field(default_factory=list)
    jump: bool = True


def _wrinkling_jump(model, states, phi_hat, settings):
    """Where the first valid run of ``states`` jumps: the first pair of neighbouring states whose wrinkled fraction
    ``w`` differs by more than :data:`WRINKLE_JUMP` after :data:`END_ROUNDS` rounds of :data:`END_SAMPLES` states
    between them (each round keeps the first pair that still differs by more). A ring electrode under tension-field
    theory: the taut state at ``λ0 = 1.65068`` has ``w = 0``, the next one ``w = 0.6`` (the whole electroded
    annulus 0.2–0.8 wrinkled) and 3.5 → 20.8 in volume; the states with ``λ0`` there and the volumes between are
    not reached by shooting from the pole, and a spline through the jump rings (false volume folds on which a
    jump's gradient flow snapped and stalled).

    Every candidate pair is narrowed at once, one shot of all their samples per round (a steep but continuous
    onset, as where a grid starts next to the prestretch, is cleared by its first round).

    Returns
    -------
    tuple or None
        ``(states, reason)``: the states up to the last one before the jump (with the narrowing's valid states
        below it inserted) and the reason; None where the run has no jump.
    """
    ok = states.ok
    if not ok.any():
        return None
    run = first_valid_run(ok)
    w = states.wrinkled_fraction
    lam = states.pole_stretch
    from .curves import _take

    pairs = [
        _JumpCandidate(i, float(lam[i]), float(w[i]), float(lam[i + 1]), float(w[i + 1]))
        for i in range(run.start, run.stop - 1)
        if np.isfinite(w[i]) and np.isfinite(w[i + 1]) and abs(w[i + 1] - w[i]) > WRINKLE_JUMP
    ]
    for _ in range(END_ROUNDS):
        live = [c for c in pairs if c.jump]
        if not live:
            return None
        pts = np.concatenate([np.linspace(c.a, c.b, END_SAMPLES + 2)[1:-1] for c in live])
        shot = solve_states(model, pts, phi_hat, settings)
        for j, c in enumerate(live):
            part = slice(j * END_SAMPLES, (j + 1) * END_SAMPLES)
            st, p = _take(shot, part), pts[part]
            ws = np.concatenate([[c.wa], st.wrinkled_fraction, [c.wb]])
            gaps = np.flatnonzero(~(np.abs(np.diff(ws)) <= WRINKLE_JUMP))  # NaN (a failed state) counts as a gap
            if not gaps.size:
                c.jump = False
                continue
            k = int(gaps[0])  # the pair (ws[k], ws[k + 1]); p[k − 1] is the last sample below it
            if k > 0:
                c.extra.append(_take(st, slice(0, k)))
                c.a, c.wa = float(p[k - 1]), float(ws[k])
            if k < p.size:
                c.b, c.wb = float(p[k]), float(ws[k + 1])
    for c in pairs:
        if not c.jump:
            continue
        below = _take(states, slice(0, c.index + 1))
        kept = _concatenate([below, *c.extra]) if c.extra else below
        why = (
            f"the states jump at pole stretch {c.a:.6g}: the wrinkled fraction {c.wa:.3g} -> {c.wb:.3g} within "
            f"{c.b - c.a:.2g} in λ0 (shooting from the pole does not reach the states between)"
        )
        return kept, why
    return None


def _concatenate(parts):
    """One :class:`~coexist.shooting.MembraneStates` of the ``parts`` in order (array fields joined, list fields
    joined where every part has them, derivatives dropped)."""
    first = parts[0]
    kw: dict = {}
    for name, value in first.__dict__.items():
        if isinstance(value, np.ndarray):
            kw[name] = np.concatenate([getattr(p, name) for p in parts])
        elif isinstance(value, list) and all(isinstance(getattr(p, name), list) for p in parts):
            kw[name] = [x for p in parts for x in getattr(p, name)]
        elif name == "derivatives":
            kw[name] = None
        else:
            kw[name] = value
    return type(first)(**kw)
