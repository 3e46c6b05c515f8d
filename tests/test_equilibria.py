"""N identical zones on a gas: configurations, exact residuals and their Jacobian, closed-form stability."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from coexist.effects import GasChamber, PressureReservoir
from coexist.equilibria import Configuration, GroupSystem, hessian_eigenvalues, merged, two_group
from coexist.errors import SceneError
from coexist.model import build_model
from coexist.settings import SolverSettings


def dense_hessian(counts, a, c):
    """The N×N Hessian ``diag(a_i) + c 1 1ᵀ`` built zone by zone (what the closed form avoids)."""
    diag = np.concatenate([np.full(n, aj) for n, aj in zip(counts, a)])
    return np.diag(diag) + c * np.ones((diag.size, diag.size))


@settings(max_examples=60, deadline=None, derandomize=True)
@given(
    counts=st.lists(st.integers(1, 7), min_size=1, max_size=4),
    a=st.lists(st.floats(-3, 3), min_size=4, max_size=4),
    c=st.floats(0.0, 5.0),
)
def test_closed_form_eigenvalues_are_the_dense_ones(counts, a, c):
    a = a[: len(counts)]
    closed = sorted(v for v, mult, _ in hessian_eigenvalues(counts, a, c) for _ in range(mult))
    dense = np.linalg.eigvalsh(dense_hessian(counts, a, c))
    assert len(closed) == sum(counts)
    np.testing.assert_allclose(closed, dense, atol=1e-10 * (1 + np.max(np.abs(dense))))


def test_configuration_labels_and_merging():
    assert Configuration((3,)).label == "homogeneous"
    assert Configuration((2, 1)).label == "1 of 3 bulged"
    assert Configuration((1, 2)).label == "2 of 3 bulged"
    assert two_group(3, 0) == Configuration((3,)) and two_group(3, 1) == Configuration((2, 1))
    conf, u = merged(Configuration((1, 1)), [1.2, 1.2 + 1e-9])
    assert conf == Configuration((2,)) and u.size == 1
    conf, u = merged(Configuration((2, 1)), [1.5, 1.1])
    assert conf == Configuration((1, 2)) and list(u) == [1.1, 1.5]
    with pytest.raises(SceneError):
        Configuration((0, 3))


def test_gas_law_and_reservoir():
    gas = GasChamber.closed_at(100.0, 50.0, 2.0, 6.0)
    assert gas.pressure(6.0) == pytest.approx(2.0, rel=1e-15)
    # c = −dp/dV by a central difference
    h = 1e-4
    assert gas.stiffness(6.0) == pytest.approx(-(gas.pressure(6 + h) - gas.pressure(6 - h)) / (2 * h), rel=1e-7)
    # dG_gas/dV = −p_gauge
    assert (gas.free_energy(6 + h) - gas.free_energy(6 - h)) / (2 * h) == pytest.approx(-gas.pressure(6.0), rel=1e-7)
    res = PressureReservoir(1.5)
    assert res.pressure(10.0) == 1.5 and res.stiffness(10.0) == 0.0
    with pytest.raises(SceneError):
        GasChamber(-1.0, 50.0, 2.0)


@pytest.mark.parametrize(
    "counts, u, phi", [((3,), [0.9], 0.2), ((2, 1), [0.6, 2.1], 0.22), ((1, 1, 2), [0.5, 1.2, 2.0], 0.1)]
)
def test_residual_jacobian_is_the_derivative_of_the_residual(counts, u, phi):
    """Every column of the exact Jacobian (variational equations, chain rule through the gas and the
    divided differences) against five-point differences of the residual itself (rtol 1e-12 states)."""
    model = build_model("gent", 97.0)
    gas = GasChamber.closed_at(30.0, 45.0, 1.8, 7.0)
    system = GroupSystem(model, gas, Configuration(counts), SolverSettings(rtol=1e-12))
    u = np.array(u, dtype=float)
    res = system.residual(u[None, :], np.array([phi]))
    assert res.states.ok.all()
    h = 1e-4
    for k in range(len(u) + 1):
        pts = []
        for m in (-2, -1, 1, 2):
            uu, pp = u.copy(), phi
            if k < len(u):
                uu[k] += m * h
            else:
                pp += m * h
            pts.append(system.residual(uu[None, :], np.array([pp])).r[0])
        fd = (pts[0] - 8 * pts[1] + 8 * pts[2] - pts[3]) / (12 * h)
        np.testing.assert_allclose(res.J[0, :, k], fd, rtol=1e-6, atol=1e-7, err_msg=f"column {k}")


def test_homogeneous_residual_vanishes_at_the_closing_state():
    """The gas closed at the zones' state at 0 V: that state is an equilibrium to the shooting's precision."""
    from coexist.shooting import solve_states

    model = build_model("gent", 97.0)
    st0 = solve_states(model, [1.8], 0.0).require_ok()
    gas = GasChamber.closed_at(30.0, 45.0, float(st0.p_hat[0]), 3 * float(st0.v_hat[0]))
    system = GroupSystem(model, gas, Configuration((3,)), SolverSettings())
    res = system.residual(np.array([[np.sqrt(0.8)]]), np.array([0.0]))
    assert abs(res.r[0, 0]) < 10 * SolverSettings().rtol * float(st0.p_hat[0])  # the shooting's own precision
