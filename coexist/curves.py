"""The two curve families of one zone: ``p̂(V̂)`` at fixed ``Φ̂`` and ``Φ̂(Q̂)`` at fixed ``p̂``.

Both are traced by the pole stretch ``λ0``, which does not turn where pressure, voltage or volume
do, so the curves pass through their limit points. Limit points are then located precisely by
solving for the extremum (Chebyshev interpolation of the quantity on a shrinking bracket around
the grid extremum, converged to the solver tolerance), not read off the grid.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .errors import ModelRangeError, SceneError
from .model import MembraneModel
from .settings import SolverSettings
from .shooting import OK, MembraneStates, reason_tag, reason_text, solve_states

_STATE_FIELDS = ("pole_stretch", "phi_hat", "p_hat", "v_hat", "q_hat", "psi_hat", "apex_height", "max_field",
                 "min_tension")


@dataclass
class LimitPoint:
    """A turning point along a curve: ``kind`` is e.g. ``pressure_max`` or ``voltage_max``."""

    kind: str
    pole_stretch: float
    p_hat: float
    v_hat: float
    phi_hat: float
    q_hat: float
    psi_hat: float

    def to_dict(self) -> dict:
        return dict(self.__dict__)


@dataclass
class Curve:
    """One curve of equilibrium states of a clamped zone, traced by the pole stretch.

    Attributes
    ----------
    family : str
        ``"pressure_volume"`` (fixed ``phi_hat``) or ``"voltage_charge"`` (fixed ``p_hat``).
    fixed : float
        The value held fixed (``Φ̂`` or ``p̂``).
    states : MembraneStates
        The valid states, in order of increasing pole stretch (all with status OK).
    limit_points : list of LimitPoint
    starts_because, stopped_because : str or None
        Why the curve starts later or ends earlier than the requested pole-stretch range.
    """

    family: str
    fixed: float
    states: MembraneStates
    limit_points: list = field(default_factory=list)
    starts_because: str | None = None
    stopped_because: str | None = None
    rtol: float = 0.0

    def __getattr__(self, name):
        if name in _STATE_FIELDS:
            return getattr(self.states, name)
        raise AttributeError(name)

    def to_dict(self) -> dict:
        s = self.states
        out = {
            "family": self.family,
            ("phi_hat" if self.family == "pressure_volume" else "p_hat"): self.fixed,
            "pole_stretch": s.pole_stretch.tolist(),
            "p_hat": s.p_hat.tolist(),
            "v_hat": s.v_hat.tolist(),
            "q_hat": s.q_hat.tolist(),
            "psi_hat": s.psi_hat.tolist(),
            "apex_height": s.apex_height.tolist(),
            "max_field_hat": s.max_field.tolist(),
            "min_tension_hat": s.min_tension.tolist(),
            "limit_points": [lp.to_dict() for lp in self.limit_points],
            "relative_tolerance": self.rtol,
        }
        if self.family == "voltage_charge":
            out["phi_hat_values"] = s.phi_hat.tolist()
        if self.starts_because:
            out["starts_because"] = self.starts_because
        if self.stopped_because:
            out["stopped_because"] = self.stopped_because
        return out


def _take(states: MembraneStates, index) -> MembraneStates:
    kw = {}
    for name, value in states.__dict__.items():
        if isinstance(value, np.ndarray):
            kw[name] = value[index]
        elif name == "shapes" and value is not None:
            kw[name] = [value[i] for i in np.arange(len(value))[index]]
        else:
            kw[name] = value
    return MembraneStates(**kw)


def _concat(a: MembraneStates, b: MembraneStates) -> MembraneStates:
    kw = {}
    for name, value in a.__dict__.items():
        if isinstance(value, np.ndarray):
            kw[name] = np.concatenate([value, getattr(b, name)])
        else:
            kw[name] = None
    return MembraneStates(**kw)


def _valid_run(states: MembraneStates, pole_stretch):
    """The first contiguous run of valid states, and why the range was cut before and after it."""
    ok = states.ok
    if not ok.any():
        i = 0
        raise ModelRangeError(
            f"no valid state anywhere in pole stretch {pole_stretch[0]:.4g}..{pole_stretch[-1]:.4g}"
            f" (at {pole_stretch[i]:.4g}: {reason_text(states.status[i])})",
            reason_tag(states.status[i]),
        )
    first = int(np.argmax(ok))
    last = first
    while last + 1 < ok.size and ok[last + 1]:
        last += 1
    starts = None
    if first > 0:
        code = states.status[first - 1]
        starts = (f"{reason_tag(code)}: below pole stretch {pole_stretch[first]:.6g} "
                  f"{reason_text(code)}")
    stopped = None
    if last + 1 < ok.size:
        code = states.status[last + 1]
        stopped = (f"{reason_tag(code)}: beyond pole stretch {pole_stretch[last]:.6g} "
                   f"{reason_text(code)}")
    return slice(first, last + 1), starts, stopped


def refine_extremum(evaluate, a: float, b: float, maximum: bool, settings: SolverSettings, nodes: int = 9):
    """Locate the extremum of ``g(λ0)`` in ``[a, b]`` by Chebyshev interpolation on shrinking brackets.

    ``evaluate(l0_array)`` returns ``(g_values, MembraneStates)``. The interpolant of degree
    ``nodes - 1`` is differentiated and its stationary point taken; the bracket is shrunk around it
    until it is narrower than ``settings.limit_point_xtol`` (relative) or the value stops changing.
    Returns the states at the extremum (one entry).
    """
    sign = 1.0 if maximum else -1.0
    best = None
    for _ in range(8):
        k = np.arange(nodes)
        x = 0.5 * (a + b) + 0.5 * (b - a) * np.cos(np.pi * (k + 0.5) / nodes)[::-1]
        g, st = evaluate(x)
        if not np.all(np.isfinite(g)):
            raise ModelRangeError(f"no valid state near the limit point in pole stretch {a:.6g}..{b:.6g}",
                                  "no_equilibrium")
        cheb = np.polynomial.Chebyshev.fit(x, sign * g, nodes - 1, domain=[a, b])
        roots = cheb.deriv().roots()
        roots = roots[np.isreal(roots)].real
        roots = roots[(roots >= a) & (roots <= b)]
        cand = np.concatenate([roots, x])
        x_star = cand[np.argmax(cheb(cand))]
        g_star, s_star = evaluate(np.array([x_star]))
        width = b - a
        if best is not None and abs(g_star[0] - best[0]) <= 0.1 * settings.rtol * max(1.0, abs(g_star[0])) \
                and width < 1e-3 * x_star:
            best = (g_star[0], s_star)
            break
        best = (g_star[0], s_star)
        if width <= settings.limit_point_xtol * x_star:
            break
        half = max(width / 16, 2 * settings.limit_point_xtol * x_star)
        a, b = max(a, x_star - half), min(b, x_star + half)
    return best[1]


def _limit_point(kind: str, s: MembraneStates) -> LimitPoint:
    return LimitPoint(kind=kind, pole_stretch=float(s.pole_stretch[0]), p_hat=float(s.p_hat[0]),
                      v_hat=float(s.v_hat[0]), phi_hat=float(s.phi_hat[0]), q_hat=float(s.q_hat[0]),
                      psi_hat=float(s.psi_hat[0]))


def _find_extrema(values, pole_stretch, evaluate, names, settings):
    """Refine every interior discrete extremum of ``values`` along the grid."""
    found = []
    d = np.diff(values)
    for i in range(1, values.size - 1):
        if d[i - 1] > 0 and d[i] <= 0:
            kind, maximum = names[0], True
        elif d[i - 1] < 0 and d[i] >= 0:
            kind, maximum = names[1], False
        else:
            continue
        s = refine_extremum(evaluate, pole_stretch[i - 1], pole_stretch[i + 1], maximum, settings)
        found.append((kind, s))
    return found


def _check_range(pole_stretch, model):
    l0 = np.asarray(pole_stretch, dtype=float)
    if l0.ndim != 1 or l0.size < 3:
        raise SceneError("needs at least 3 pole stretches", "pole_stretch")
    if np.any(np.diff(l0) <= 0):
        raise SceneError("pole stretches must increase", "pole_stretch")
    if l0[0] <= model.prestretch:
        raise SceneError(f"pole stretch must exceed the prestretch {model.prestretch:g}, got {l0[0]:g}",
                         "pole_stretch")
    return l0


def pressure_volume_curve(model: MembraneModel, phi_hat: float = 0.0, pole_stretch=None,
                          settings: SolverSettings | None = None) -> Curve:
    """The ``p̂–V̂`` curve of a clamped zone at fixed normalised voltage ``Φ̂``.

    Parameters
    ----------
    model : MembraneModel
    phi_hat : float
        ``Φ̂ = (Φ/H)√(ε/μ)``.
    pole_stretch : array_like, optional
        Increasing pole stretches; default 200 points from ``1.01 λpre`` to ``4``.
    settings : SolverSettings, optional

    Returns
    -------
    Curve
        With the pressure maxima/minima (and volume folds) refined to the solver tolerance.

    Examples
    --------
    >>> from coexist import MembraneModel, pressure_volume_curve
    >>> c = pressure_volume_curve(MembraneModel(), phi_hat=0.0)
    >>> round(c.limit_points[0].p_hat, 3)
    1.879
    """
    settings = settings or SolverSettings()
    if pole_stretch is None:
        pole_stretch = np.linspace(1.01 * model.prestretch, max(4.0, 1.5 * model.prestretch), 200)
    l0 = _check_range(pole_stretch, model)
    states = solve_states(model, l0, phi_hat, settings)
    run, starts, stopped = _valid_run(states, l0)
    states = _take(states, run)
    grid = states.pole_stretch

    def by_pressure(x):
        s = solve_states(model, x, phi_hat, settings)
        return np.where(s.ok, s.p_hat, np.nan), s

    def by_volume(x):
        s = solve_states(model, x, phi_hat, settings)
        return np.where(s.ok, s.v_hat, np.nan), s

    limits = [_limit_point(k, s) for k, s in _find_extrema(states.p_hat, grid, by_pressure,
                                                         ("pressure_max", "pressure_min"), settings)]
    limits += [_limit_point(k, s) for k, s in _find_extrema(states.v_hat, grid, by_volume,
                                                          ("volume_max", "volume_min"), settings)]
    limits.sort(key=lambda lp: lp.pole_stretch)
    return Curve("pressure_volume", float(phi_hat), states, limits, starts, stopped, settings.rtol)


def voltage_at_pressure(model: MembraneModel, pole_stretch, p_hat: float, settings: SolverSettings | None = None,
                        iterations: int = 60) -> MembraneStates:
    """States at given pole stretches that carry the pressure ``p̂``: solves ``p̂(λ0, Φ̂) = p̂`` for ``Φ̂``.

    The pressure falls as the voltage rises at fixed pole stretch; the root in ``s = Φ̂²`` is found by
    a safeguarded regula falsi (Illinois) on ``[0, s_pole]``, where ``s_pole`` is the voltage at
    which the pole tension vanishes. Pole stretches with ``p̂(λ0, 0) < p̂`` carry no voltage that
    reaches the pressure and are flagged ``no_equilibrium``; voltages at which the state fails
    (wrinkling at the clamp, ...) shrink the bracket from above.
    """
    from .shooting import NO_CLAMP

    settings = settings or SolverSettings()
    if not model.has_voltage:
        raise SceneError("a voltage-charge curve needs a model with electrostatics", "voltage")
    l0 = np.atleast_1d(np.asarray(pole_stretch, dtype=float))
    n = l0.size
    # bracket: s = 0 and the voltage that makes the pole tension vanish
    lo_s = np.zeros(n)
    hi_s = np.ones(n)
    for _ in range(60):
        grow = model.pole(l0, np.sqrt(hi_s))[0] > 0
        if not np.any(grow):
            break
        hi_s = np.where(grow, hi_s * 2, hi_s)
    a, b = lo_s.copy(), hi_s.copy()
    for _ in range(60):  # bisection of T0(λ0, √s) = 0
        mid = 0.5 * (a + b)
        pos = model.pole(l0, np.sqrt(mid))[0] > 0
        a, b = np.where(pos, mid, a), np.where(pos, b, mid)
    hi_s = a
    s0 = solve_states(model, l0, 0.0, settings)
    f_lo = np.where(s0.ok, s0.p_hat - p_hat, -np.inf)
    feasible = f_lo >= 0
    lo, hi = lo_s, hi_s
    f_hi = np.full(n, -p_hat)  # towards the pole-wrinkling voltage the pressure falls to zero
    side = np.zeros(n)
    done = ~feasible | (f_lo == 0)
    result = s0
    for _ in range(iterations):
        idx = np.flatnonzero(~done)
        if idx.size == 0:
            break
        width = hi[idx] - lo[idx]
        denom = f_lo[idx] - f_hi[idx]
        with np.errstate(all="ignore"):
            x_new = lo[idx] + f_lo[idx] * width / denom
        x_new = np.where(np.isfinite(x_new), x_new, lo[idx] + 0.5 * width)
        x_new = np.clip(x_new, lo[idx] + 1e-3 * width, hi[idx] - 1e-3 * width)
        st = solve_states(model, l0[idx], np.sqrt(x_new), settings)
        f = np.where(st.ok, st.p_hat - p_hat, -np.inf)
        up = f > 0
        # Illinois: halve the retained end's value when the same end is kept twice in a row
        keep_hi = up & (side[idx] == 1)
        keep_lo = ~up & (side[idx] == -1)
        f_hi[idx[keep_hi]] *= 0.5
        f_lo[idx[keep_lo]] *= 0.5
        lo[idx[up]], f_lo[idx[up]] = x_new[up], f[up]
        down = ~up
        hi[idx[down]] = x_new[down]
        f_hi[idx[down]] = np.where(np.isfinite(f[down]), f[down], f_hi[idx[down]])
        side[idx] = np.where(up, 1, -1)
        conv = st.ok & (np.abs(f) <= 0.1 * settings.rtol * p_hat)
        if np.any(conv):
            result = _merge(result, _take(st, conv), idx[conv])
            done[idx[conv]] = True
        stuck = ~conv & (hi[idx] - lo[idx] <= 1e-15 * hi[idx])
        done[idx[stuck]] = True
    converged = feasible & done & (result.phi_hat > 0) | (feasible & (f_lo == 0))
    status = result.status.copy()
    status[~converged & (status == OK)] = NO_CLAMP
    result.status = status
    for name in ("p_hat", "v_hat", "q_hat", "psi_hat", "apex_height", "max_field", "min_tension"):
        getattr(result, name)[status != OK] = np.nan
    return result


def _merge(base: MembraneStates, new: MembraneStates, where) -> MembraneStates:
    for name, value in base.__dict__.items():
        if isinstance(value, np.ndarray):
            value[where] = getattr(new, name)
    return base


def voltage_charge_curve(model: MembraneModel, p_hat: float, pole_stretch=None,
                         settings: SolverSettings | None = None) -> Curve:
    """The ``Φ̂–Q̂`` curve of a clamped zone at fixed normalised pressure ``p̂``.

    Traced by the pole stretch; at each ``λ0`` the voltage is the root of ``p̂(λ0, Φ̂) = p̂``
    (:func:`voltage_at_pressure`). The voltage maximum (snap-through voltage under pressure
    control) is refined to the solver tolerance.
    """
    settings = settings or SolverSettings()
    if not (np.isfinite(p_hat) and p_hat > 0):
        raise SceneError(f"p̂ must be a positive number, got {p_hat!r}", "p_hat")
    if pole_stretch is None:
        pole_stretch = np.linspace(1.01 * model.prestretch, max(4.0, 1.5 * model.prestretch), 120)
    l0 = _check_range(pole_stretch, model)
    states = voltage_at_pressure(model, l0, p_hat, settings)
    run, starts, stopped = _valid_run(states, l0)
    states = _take(states, run)

    def by_voltage(x):
        s = voltage_at_pressure(model, x, p_hat, settings)
        return np.where(s.ok, s.phi_hat, np.nan), s

    def by_charge(x):
        s = voltage_at_pressure(model, x, p_hat, settings)
        return np.where(s.ok, s.q_hat, np.nan), s

    limits = [_limit_point(k, s) for k, s in _find_extrema(states.phi_hat, states.pole_stretch, by_voltage,
                                                         ("voltage_max", "voltage_min"), settings)]
    limits += [_limit_point(k, s) for k, s in _find_extrema(states.q_hat, states.pole_stretch, by_charge,
                                                          ("charge_max", "charge_min"), settings)]
    limits.sort(key=lambda lp: lp.pole_stretch)
    return Curve("voltage_charge", float(p_hat), states, limits, starts, stopped, settings.rtol)
