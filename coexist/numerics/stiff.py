"""An implicit (backward) Euler integrator with step control and terminal events, for small stiff systems.

The ramp's jumps follow the gradient flow of the total potential over a few zone groups
(:func:`coexist.ramp.gradient_flow`): a system of a handful of unknowns whose time scales range over
many decades (a zone near its volume fold moves fast, the escape from a lost state is slow). Backward
Euler is the scheme for such a flow: ``u_{n+1} = u_n + h f(u_{n+1})`` is L-stable, and for a gradient
flow it is the minimising movement (each step lowers the potential), so a large step never leaves the
basin the flow is in. The local error of a step is estimated by its difference from the trapezoidal
rule, ``e = (h/2)(f(u_{n+1}) − f(u_n))``, and the step adapts to keep ``e`` within
``atol + rtol |u|``.

Written here rather than taken from :func:`scipy.integrate.solve_ivp` (``LSODA`` was used before)
because importing :mod:`scipy.integrate` costs 0.35 s of a ramp's 1 s, and because LSODA's first
step, taken from the length of the time window, sent it into half a million tiny steps on one flow
(``tests/test_numerics.py`` has the checks: an exact linear stiff system, an event located, a
gradient flow's end).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["FlowResult", "rosenbrock2"]


@dataclass
class FlowResult:
    """Where a :func:`rosenbrock2` integration ended.

    Attributes
    ----------
    t : float
        The time reached.
    u : ndarray
        The state there (at a terminal event: where its function crosses zero).
    event : int or None
        Index of the terminal event that stopped it, None if none did.
    status : str
        ``"event"``, ``"t_end"`` (the window is done) or ``"step_limit"``.
    steps : int
        Accepted steps.
    """

    t: float
    u: np.ndarray
    event: int | None
    status: str
    steps: int

    def __post_init__(self):
        self.t = float(self.t)


def _jacobian(f, t, u, fu):
    m = u.size
    J = np.empty((m, m))
    for k in range(m):
        du = 1.5e-8 * max(1.0, abs(u[k]))
        w = u.copy()
        w[k] += du
        J[:, k] = (f(t, w) - fu) / du
    return J


def rosenbrock2(
    f,
    u0,
    t_end: float,
    events=(),
    rtol: float = 1e-6,
    atol: float = 1e-9,
    max_steps: int = 20000,
    jac=None,
) -> FlowResult:
    """Integrate the autonomous ``du/dt = f(t, u)`` from ``t = 0`` by the L-stable two-stage Rosenbrock
    method ROS2, until ``t_end`` or a terminal event.

    With ``γ = 1 + 1/√2`` and the Jacobian ``J`` of ``f`` (forward differences, once per step):
    ``(I − γhJ) k1 = f(u)``, ``(I − γhJ) k2 = f(u + h k1) − 2 k1``, ``u_{n+1} = u + (3/2) h k1 + (1/2) h k2``
    (second order for any ``J``: Verwer, Spee, Blom and Hundsdorfer, SIAM J. Sci. Comput. 20, 1999).
    The embedded first-order solution is the linearly implicit Euler step ``u + h k1``; their difference
    ``(h/2)(k1 + k2)``, measured as ``‖e / (atol + rtol|u|)‖_rms``, accepts or rejects the step and sets
    the next one. After each accepted step every event function ``g(t, u)`` is checked for a sign change
    from positive to non-positive; the first one found is located on the step's linear interpolant by
    bisection and ends the integration there.

    Parameters
    ----------
    f : callable
        ``f(t, u) -> ndarray`` of the shape of ``u`` (``t`` is passed but the method assumes ``f`` does
        not depend on it).
    u0 : array_like, shape (m,)
        The start.
    t_end : float
        End of the window (> 0).
    events : sequence of callable, optional
        Terminal event functions ``g(t, u) -> float``, triggered when ``g`` falls through zero.
    rtol, atol : float, optional
        Relative and absolute tolerance of the local error (default 1e-6 and 1e-9).
    max_steps : int, optional
        Accepted steps before giving up with status ``"step_limit"`` (default 20000).
    jac : callable, optional
        ``jac(t, u) -> ndarray (m, m)``, the Jacobian of ``f``; default forward differences (``m`` more
        evaluations of ``f`` per step). The method is second order for any ``J``: an exact one only makes
        the steps cheaper and the linear stability exact.

    Returns
    -------
    FlowResult
        Time, state, which event (if any) and why it stopped.

    Examples
    --------
    >>> r = rosenbrock2(lambda t, u: -u, [1.0], 50.0, events=[lambda t, u: u[0] - 0.5], rtol=1e-8)
    >>> r.status, round(r.t, 4)
    ('event', 0.6931)
    """
    gamma = 1.0 + 1.0 / np.sqrt(2.0)
    u = np.array(u0, dtype=float)
    t = 0.0
    fu = np.asarray(f(t, u), dtype=float)
    g_prev = [float(g(t, u)) for g in events]
    J = _jacobian(f, t, u, fu) if jac is None else np.asarray(jac(t, u), dtype=float)
    norm = float(np.max(np.abs(J))) if J.size else 0.0
    h = min(t_end, 0.01 / norm if norm > 0 else 1e-3 * t_end)
    eye = np.eye(u.size)
    steps = 0
    cap = _growth_cap(J)
    while t < t_end:
        if steps >= max_steps:
            return FlowResult(t, u, None, "step_limit", steps)
        h = min(h, t_end - t, cap)
        err = np.inf
        try:
            Minv = np.linalg.inv(eye - (gamma * h) * J)  # a few unknowns: one inverse serves both stages
            k1 = Minv @ fu
            k2 = Minv @ (np.asarray(f(t + h, u + h * k1), dtype=float) - 2.0 * k1)
            w = u + h * (1.5 * k1 + 0.5 * k2)
            scale = atol + rtol * np.maximum(np.abs(u), np.abs(w))
            err = float(np.sqrt(np.mean((0.5 * h * (k1 + k2) / scale) ** 2)))
        except np.linalg.LinAlgError:
            pass
        if not (np.isfinite(err) and err <= 1.0):
            h *= 0.25 if not np.isfinite(err) else max(0.2, 0.9 / np.sqrt(err))
            if h <= 1e-14 * max(1.0, t):
                return FlowResult(t, u, None, "step_limit", steps)
            continue
        steps += 1
        g_new = [float(g(t + h, w)) for g in events]
        hit = [k for k in range(len(events)) if g_prev[k] > 0 and g_new[k] <= 0]
        if hit:
            k = hit[0]
            a, b = 0.0, 1.0  # locate g = 0 on the step's interpolant u + s (w − u)
            for _ in range(60):
                s = 0.5 * (a + b)
                if events[k](t + s * h, u + s * (w - u)) > 0:
                    a = s
                else:
                    b = s
            return FlowResult(t + b * h, u + b * (w - u), k, "event", steps)
        t, u, g_prev = t + h, w, g_new
        fu = np.asarray(f(t, u), dtype=float)
        h *= min(5.0, max(0.2, 0.9 / np.sqrt(max(err, 1e-10))))
        J = _jacobian(f, t, u, fu) if jac is None else np.asarray(jac(t, u), dtype=float)
        cap = _growth_cap(J)
    return FlowResult(t, u, None, "t_end", steps)


def _growth_cap(J) -> float:
    """The longest step that still lets a growing mode grow: ``0.5/λ+``, ``λ+`` the largest positive real part of
    the eigenvalues of ``J`` (``inf`` when none grows).

    An L-stable step damps every mode whose ``|hλ|`` is large, a growing one (``λ > 0``) as well: past ``hλ+ ≫ 1``
    the integration settles on a saddle it should leave. Two zones on a stiff gas (``p̂atm`` = 1e8) leaving their
    split slowly (``λ+`` ≈ 1e-4) beside a gas mode of ``−6e6``: the steps grew to 1e7 and the flow sat at the saddle
    until its end time ("did not settle (stalled)")."""
    if not (J.size and np.all(np.isfinite(J))):
        return np.inf
    grow = float(np.max(np.linalg.eigvals(J).real))
    return 0.5 / grow if grow > 0 else np.inf
