"""A second, independent method for the clamped membrane: a boundary value problem.

The shooting solver (:func:`coexist.shooting.solve_states`) integrates an initial value problem
from the pole with a trial pressure and rescales the result (the ``R → cR, p → p/c`` invariance).
Here the same physical problem is posed the other way round, as a two-point boundary value problem
solved by collocation (:func:`scipy.integrate.solve_bvp`) on ``R̂ ∈ [ε, 1]`` with the pressure
``p̂`` as unknown parameter:

- states ``λ1, λ2, θ`` and the quadratures ``V̂, Q̂, Ψ̂, ẑ``;
- at ``R̂ = ε``: the pole series (``λ1 = λ0 + aε²``, ``λ2 = λ0 + bε²``, ``θ = cε``, quadratures from
  their leading terms);
- at ``R̂ = 1``: ``λ2 = 1`` (clamp, no prestretch).

Nothing of :mod:`coexist.model` is used to build it: the tensions of the neo-Hookean and Gent
membranes with voltage are derived by hand below from PHYSICS.md, and the pole series is derived
again in :func:`pole_series`. Only the final numbers are compared.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_bvp
from scipy.optimize import brentq

from coexist.effects import Gent
from coexist.model import MembraneModel
from coexist.settings import SolverSettings
from coexist.shooting import OK, solve_states

#: radius where the BVP starts; the pole series is accurate to O(ε⁴) in the stretches there
POLE_RADIUS = 3e-4
#: collocation residual tolerance of solve_bvp (1e-10 runs out of nodes at λ0 = 3.5)
BVP_TOL = 1e-8
#: Jlim of the Gent case
GENT_JLIM = 97.0

# Agreement measured between this BVP (tol 1e-8, ε = 3e-4) and the shooting solver at rtol 1e-13,
# maximum over the 16 cases of test_bvp_agrees_with_shooting (neo-Hookean and Gent, Φ̂ = 0 and 0.1,
# λ0 = 1.2, 1.8, 2.5, 3.5), all maxima at λ0 = 1.2:
#   p̂: 5.4e-13,  V̂: 1.4e-11,  Q̂: 2.3e-12,  Ψ̂: 1.8e-11,  ẑ: 5.2e-12  (relative).
# The tolerances below are about 10 times these. The disagreement is the BVP's: it grows with the
# pole radius like ε³–ε⁴ (p̂: 1.2e-7 at ε = 1e-2, 4.9e-6 at ε = 3e-2) and with the collocation
# tolerance (p̂: 1.2e-9, V̂: 3.3e-9 at tol 1e-6), while the shooting result is fixed.
REL_TOL_P = 6e-12
REL_TOL_V = 1.5e-10
REL_TOL_Q = 3e-11
REL_TOL_PSI = 2e-10
REL_TOL_Z = 6e-11


# --- hand-derived material law ---------------------------------------------------------------------


def free_energy(l1, l2, phi, jlim=None):
    """Free energy at fixed voltage over ``μ``, ``W* = Ws/μ − Φ̂² λ1² λ2² / 2``.

    Parameters
    ----------
    l1, l2 : float or ndarray
        Meridional and hoop stretch.
    phi : float
        Normalised voltage ``Φ̂``.
    jlim : float or None
        Gent limit ``Jlim``; ``None`` for neo-Hookean.

    Returns
    -------
    float or ndarray
    """
    invariant = l1**2 + l2**2 + 1.0 / (l1 * l2) ** 2 - 3.0
    if jlim is None:
        elastic = 0.5 * invariant
    else:
        elastic = -0.5 * jlim * np.log(1.0 - invariant / jlim)
    return elastic - 0.5 * phi**2 * l1**2 * l2**2


def tensions(l1, l2, phi, jlim=None):
    """Nominal tensions over ``μH`` and the derivatives of ``T̂1``, derived by hand.

    With ``I = λ1² + λ2² + λ1⁻²λ2⁻² − 3``, ``s1 = ½ ∂I/∂λ1 = λ1 − λ1⁻³λ2⁻²``,
    ``s2 = λ2 − λ1⁻²λ2⁻³`` and the Gent factor ``g = 1/(1 − I/Jlim)`` (``g = 1`` for neo-Hookean,
    ``∂g/∂λi = 2 g² si / Jlim``):

    - ``T̂1 = g s1 − Φ̂² λ1 λ2²``, ``T̂2 = g s2 − Φ̂² λ1² λ2``
    - ``∂T̂1/∂λ1 = 2g²s1²/Jlim + g (1 + 3λ1⁻⁴λ2⁻²) − Φ̂² λ2²``
    - ``∂T̂1/∂λ2 = 2g²s1s2/Jlim + 2g λ1⁻³λ2⁻³ − 2Φ̂² λ1 λ2``

    Parameters
    ----------
    l1, l2 : float or ndarray
        Meridional and hoop stretch.
    phi : float
        Normalised voltage ``Φ̂``.
    jlim : float or None
        Gent limit ``Jlim``; ``None`` for neo-Hookean.

    Returns
    -------
    tuple of (float or ndarray)
        ``(T̂1, T̂2, ∂T̂1/∂λ1, ∂T̂1/∂λ2)``.
    """
    inv = 1.0 / (l1 * l2) ** 2
    s1 = l1 - inv / l1
    s2 = l2 - inv / l2
    ds1_dl1 = 1.0 + 3.0 * inv / l1**2
    ds1_dl2 = 2.0 * inv / (l1 * l2)
    if jlim is None:
        g, dg_factor = 1.0, 0.0
    else:
        invariant = l1**2 + l2**2 + inv - 3.0
        g = 1.0 / (1.0 - invariant / jlim)
        dg_factor = 2.0 * g**2 / jlim
    t1 = g * s1 - phi**2 * l1 * l2**2
    t2 = g * s2 - phi**2 * l1**2 * l2
    t11 = dg_factor * s1 * s1 + g * ds1_dl1 - phi**2 * l2**2
    t12 = dg_factor * s1 * s2 + g * ds1_dl2 - 2.0 * phi**2 * l1 * l2
    return t1, t2, t11, t12


def pole_series(l0, p, phi, jlim, radius):
    """The state at a small radius from the series at the pole.

    With ``λ1 = λ0 + aR²``, ``λ2 = λ0 + bR²``, ``θ = cR`` and, at ``λ1 = λ2 = λ0``,
    ``T̂1 = T̂2 = T0``, ``∂T̂1/∂λ1 = ∂T̂2/∂λ2 = α``, ``∂T̂1/∂λ2 = ∂T̂2/∂λ1 = β``:

    - normal balance at order ``R``: ``2 T0 c = p λ0²``;
    - ``λ2' = (λ1 cos θ − λ2)/R`` at order ``R``: ``a = 3b + λ0 c²/2``;
    - ``(R T̂1)' = T̂2 cos θ`` at order ``R²``: ``a(3α − β) + b(3β − α) = −T0 c²/2``,
      hence ``b = −c² (T0 + (3α − β) λ0) / (16 α)``.

    The quadratures start from their leading terms: ``V̂ = π λ0³ c R⁴/4``, ``Q̂ = π Φ̂ λ0⁴ R²``,
    ``Ψ̂ = π W*(λ0, λ0) R²``, ``ẑ = λ0 c R²/2``.

    Parameters
    ----------
    l0, p, phi : float
        Pole stretch, pressure ``p̂`` and voltage ``Φ̂``.
    jlim : float or None
        Gent limit; ``None`` for neo-Hookean.
    radius : float
        Where to evaluate the series.

    Returns
    -------
    ndarray, shape (7,)
        ``(λ1, λ2, θ, V̂, Q̂, Ψ̂, ẑ)`` at ``radius``.
    """
    t0, _, alpha, beta = tensions(l0, l0, phi, jlim)
    c = p * l0**2 / (2.0 * t0)
    b = -(c**2) * (t0 + (3.0 * alpha - beta) * l0) / (16.0 * alpha)
    a = 3.0 * b + l0 * c**2 / 2.0
    r2 = radius**2
    return np.array(
        [
            l0 + a * r2,
            l0 + b * r2,
            c * radius,
            math.pi * l0**3 * c * r2**2 / 4.0,
            math.pi * phi * l0**4 * r2,
            math.pi * free_energy(l0, l0, phi, jlim) * r2,
            l0 * c * r2 / 2.0,
        ]
    )


def membrane_rhs(radius, y, p, phi, jlim):
    """Right-hand side of the membrane equations of PHYSICS.md (``' = d/dR̂``).

    ``λ2' = (λ1 cos θ − λ2)/R``; ``(R T̂1)' = T̂2 cos θ`` solved for ``λ1'``;
    ``θ' = (p̂ λ1 λ2 R − T̂2 sin θ)/(R T̂1)``; ``V̂' = π (λ2 R)² λ1 sin θ``,
    ``Q̂' = 2π Φ̂ λ1² λ2² R``, ``Ψ̂' = 2π W* R``, ``ẑ' = λ1 sin θ``.

    Parameters
    ----------
    radius : ndarray, shape (n,)
    y : ndarray, shape (7, n)
        ``(λ1, λ2, θ, V̂, Q̂, Ψ̂, ẑ)``.
    p : float
        Pressure ``p̂``.
    phi : float
    jlim : float or None

    Returns
    -------
    ndarray, shape (7, n)
    """
    l1, l2, theta = y[0], y[1], y[2]
    t1, t2, t11, t12 = tensions(l1, l2, phi, jlim)
    cos, sin = np.cos(theta), np.sin(theta)
    dl2 = (l1 * cos - l2) / radius
    dl1 = (t2 * cos - t1 - radius * t12 * dl2) / (radius * t11)
    dtheta = (p * l1 * l2 * radius - t2 * sin) / (radius * t1)
    dvolume = math.pi * (l2 * radius) ** 2 * l1 * sin
    dcharge = 2.0 * math.pi * phi * (l1 * l2) ** 2 * radius
    dpotential = 2.0 * math.pi * free_energy(l1, l2, phi, jlim) * radius
    dheight = l1 * sin
    return np.vstack([dl1, dl2, dtheta, dvolume, dcharge, dpotential, dheight])


def spherical_cap_guess(l0, phi, jlim, radius):
    """Initial guess: a spherical cap whose arc is uniformly stretched by ``λ0``.

    The cap half-angle ``α`` solves ``sin α / α = 1/λ0``; the point at ``R̂`` sits at polar angle
    ``αR̂`` of a sphere of radius ``1/sin α``, so ``θ = αR̂``, ``λ1 = α/sin α``,
    ``λ2 = sin(αR̂)/(R̂ sin α)``, and at the pole ``p̂ = 2 T̂1(λ0, λ0) α / λ0²``.

    Returns
    -------
    y : ndarray, shape (7, n)
    p : float
    """
    alpha = brentq(lambda x: math.sin(x) / x - 1.0 / l0, 1e-9, math.pi)
    sphere = 1.0 / math.sin(alpha)
    l1 = np.full_like(radius, alpha * sphere)
    r = sphere * np.sin(alpha * radius)
    l2 = r / radius
    theta = alpha * radius
    y = np.zeros((7, radius.size))
    y[0], y[1], y[2] = l1, l2, theta
    # quadratures of the guess by the trapezoidal rule (only a starting point)
    rates = membrane_rhs(radius, y, 0.0, phi, jlim)[3:]
    steps = np.diff(radius)
    y[3:, 1:] = np.cumsum(0.5 * steps * (rates[:, 1:] + rates[:, :-1]), axis=1)
    p = 2.0 * tensions(l0, l0, phi, jlim)[0] * alpha / l0**2
    return y, p


def solve_clamped_bvp(l0, phi, jlim=None, pole_radius=POLE_RADIUS, tol=BVP_TOL, nodes=400):
    """The clamped membrane of unit radius at pole stretch ``λ0``, by collocation.

    Parameters
    ----------
    l0 : float
        Pole stretch.
    phi : float
        Voltage ``Φ̂``.
    jlim : float or None
        Gent limit; ``None`` for neo-Hookean.
    pole_radius : float
        ``ε``, the start of the interval.
    tol : float
        Residual tolerance of :func:`scipy.integrate.solve_bvp`.
    nodes : int
        Nodes of the initial (geometric) mesh.

    Returns
    -------
    dict
        ``p_hat, v_hat, q_hat, psi_hat, apex_height`` and the raw ``solution``.
    """
    radius = np.geomspace(pole_radius, 1.0, nodes)
    y_guess, p_guess = spherical_cap_guess(l0, phi, jlim, radius)

    def fun(x, y, params):
        return membrane_rhs(x, y, params[0], phi, jlim)

    def bc(y_pole, y_clamp, params):
        start = pole_series(l0, params[0], phi, jlim, pole_radius)
        return np.concatenate([y_pole - start, [y_clamp[1] - 1.0]])

    with np.errstate(all="ignore"):  # finite-difference Jacobians may probe wild states
        solution = solve_bvp(fun, bc, radius, y_guess, p=[p_guess], tol=tol, bc_tol=1e-12, max_nodes=100_000)
    assert solution.status == 0, solution.message
    end = solution.y[:, -1]
    return {
        "p_hat": solution.p[0],
        "v_hat": end[3],
        "q_hat": end[4],
        "psi_hat": end[5],
        "apex_height": end[6],
        "solution": solution,
    }


# --- tests -----------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def models():
    """The project's models, built once (CasADi construction is not free)."""
    return {None: MembraneModel(), GENT_JLIM: MembraneModel(elasticity=Gent(GENT_JLIM))}


@pytest.mark.parametrize("jlim", [None, GENT_JLIM])
@pytest.mark.parametrize("phi", [0.0, 0.1])
def test_hand_tensions_are_derivatives_of_the_energy(jlim, phi):
    """The hand-derived tensions are the derivatives of the hand-written energy (central differences)."""
    l1, l2 = np.meshgrid(np.linspace(1.05, 3.0, 7), np.linspace(1.0, 2.5, 6))
    h = 1e-5
    t1, t2, t11, t12 = tensions(l1, l2, phi, jlim)
    np.testing.assert_allclose(
        t1, (free_energy(l1 + h, l2, phi, jlim) - free_energy(l1 - h, l2, phi, jlim)) / (2 * h), rtol=1e-7, atol=1e-8
    )
    np.testing.assert_allclose(
        t2, (free_energy(l1, l2 + h, phi, jlim) - free_energy(l1, l2 - h, phi, jlim)) / (2 * h), rtol=1e-7, atol=1e-8
    )
    np.testing.assert_allclose(
        t11, (tensions(l1 + h, l2, phi, jlim)[0] - tensions(l1 - h, l2, phi, jlim)[0]) / (2 * h), rtol=1e-7, atol=1e-8
    )
    np.testing.assert_allclose(
        t12, (tensions(l1, l2 + h, phi, jlim)[0] - tensions(l1, l2 - h, phi, jlim)[0]) / (2 * h), rtol=1e-7, atol=1e-8
    )


@pytest.mark.parametrize("jlim", [None, GENT_JLIM])
def test_model_tensions_match_hand_derivation(models, jlim):
    """The project's symbolic tensions equal the hand-derived ones."""
    l1, l2 = np.meshgrid(np.linspace(1.05, 3.0, 7), np.linspace(1.0, 2.5, 6))
    for phi in (0.0, 0.1, 0.3):
        ours = tensions(l1, l2, phi, jlim)
        theirs = models[jlim].tensions(l1, l2, phi)[:4]
        for mine, project in zip(ours, theirs):
            np.testing.assert_allclose(project, mine, rtol=1e-13, atol=1e-13)
        np.testing.assert_allclose(
            models[jlim].free_energy(l1, l2, phi), free_energy(l1, l2, phi, jlim), rtol=1e-13, atol=1e-13
        )


@pytest.mark.parametrize("jlim", [None, GENT_JLIM], ids=["neo-hookean", "gent97"])
@pytest.mark.parametrize("phi", [0.0, 0.1])
@pytest.mark.parametrize("l0", [1.2, 1.8, 2.5, 3.5])
def test_bvp_agrees_with_shooting(models, jlim, phi, l0):
    """Collocation (solve_bvp, unknown p̂) and shooting (rescaled IVP) give the same state."""
    bvp = solve_clamped_bvp(l0, phi, jlim)
    states = solve_states(models[jlim], [l0], phi, SolverSettings(rtol=1e-13))
    assert states.status[0] == OK
    assert states.p_hat[0] == pytest.approx(bvp["p_hat"], rel=REL_TOL_P)
    assert states.v_hat[0] == pytest.approx(bvp["v_hat"], rel=REL_TOL_V)
    assert states.q_hat[0] == pytest.approx(bvp["q_hat"], rel=REL_TOL_Q, abs=1e-14)
    assert states.psi_hat[0] == pytest.approx(bvp["psi_hat"], rel=REL_TOL_PSI)
    assert states.apex_height[0] == pytest.approx(bvp["apex_height"], rel=REL_TOL_Z)


def test_bvp_solution_satisfies_the_clamp_and_pole_conditions():
    """Sanity of the reference itself: λ2 = 1 at the clamp, λ1 ≈ λ2 ≈ λ0 near the pole, tensions positive."""
    bvp = solve_clamped_bvp(2.0, 0.1)
    solution = bvp["solution"]
    assert solution.y[1, -1] == pytest.approx(1.0, abs=1e-12)
    assert solution.y[0, 0] == pytest.approx(2.0, abs=1e-5)
    assert solution.y[1, 0] == pytest.approx(2.0, abs=1e-5)
    t1, t2, _, _ = tensions(solution.y[0], solution.y[1], 0.1)
    assert np.all(t1 > 0) and np.all(t2 > 0)


# Measured relative error of p̂ at λ0 = 2.0, Φ̂ = 0.1 against rtol 1e-13:
#   rtol  1e-4: 3.8e-07   1e-5: 1.8e-07   1e-6: 5.1e-09   1e-7: 5.3e-09
#   rtol  1e-8: 6.3e-10   1e-9: 5.6e-11   1e-10: 2.2e-12
# The error is below rtol everywhere (far below at loose tolerances, where the few steps taken are
# accurate anyway) and falls by 8e4 between rtol 1e-5 and 1e-10; it is not strictly monotone
# (1e-6 and 1e-7 give the same error).
CONVERGENCE_RTOLS = (1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10)


def test_shooting_converges_as_rtol_tightens(models):
    """p̂ from the shooting solver converges to the tight-tolerance value roughly like rtol."""
    l0, phi = 2.0, 0.1
    reference = solve_states(models[None], [l0], phi, SolverSettings(rtol=1e-13)).p_hat[0]
    errors = {}
    for rtol in CONVERGENCE_RTOLS:
        p_hat = solve_states(models[None], [l0], phi, SolverSettings(rtol=rtol)).p_hat[0]
        errors[rtol] = abs(p_hat / reference - 1.0)
    for rtol, error in errors.items():
        assert error <= 10 * rtol, (rtol, error)
    assert errors[1e-10] * 1e3 <= errors[1e-5], errors
    # and the reference itself agrees with the independent BVP
    assert reference == pytest.approx(solve_clamped_bvp(l0, phi)["p_hat"], rel=REL_TOL_P)
