"""The shooting solver against thermodynamic identities, analytical limits and a published number."""

import numpy as np
import pytest
from conftest import TIGHT, cheb_nodes

from coexist.curves import pressure_volume_curve
from coexist.effects import Gent, NeoHookean
from coexist.errors import ModelRangeError, SceneError
from coexist.model import MembraneModel
from coexist.settings import SolverSettings
from coexist.shooting import OK, WRINKLED, WRINKLED_AT_POLE, solve_states


def _interpolant(x, y, a, b):
    return np.polynomial.Chebyshev.fit(x, y, x.size - 1, domain=[a, b])


@pytest.mark.parametrize("phi", [0.0, 0.1])
def test_work_of_pressure_equals_change_of_potential(neo_hookean, phi):
    """∫ p̂ dV̂ along a curve at fixed Φ̂ equals ΔΨ̂ (dΨ̂ = p̂ dV̂ − Q̂ dΦ̂), through the pressure maximum.

    p̂ and V̂ are Chebyshev-interpolated in λ0 (spectral accuracy), the integral ∫ p̂ V̂'(λ0) dλ0 is
    computed from the interpolants; relative error must be below 1e-6 (measured: ~1e-10).
    """
    a, b = 1.05, 3.0
    x = cheb_nodes(a, b, 48)
    s = solve_states(neo_hookean, x, phi, TIGHT).require_ok()
    P, V = _interpolant(x, s.p_hat, a, b), _interpolant(x, s.v_hat, a, b)
    work = (P * V.deriv()).integ(lbnd=a)(b)
    ends = solve_states(neo_hookean, [a, b], phi, TIGHT)
    dpsi = ends.psi_hat[1] - ends.psi_hat[0]
    assert work == pytest.approx(dpsi, rel=1e-6)


@pytest.mark.parametrize("l0", [1.4, 2.0, 2.8])
def test_maxwell_relation(neo_hookean, l0):
    """∂p̂/∂Φ̂|V̂ = −∂Q̂/∂V̂|Φ̂ at several states (central differences, relative agreement 1e-5)."""
    phi, dphi, dl = 0.12, 1e-4, 1e-3
    grid = np.array([l0 - dl, l0 + dl])

    def at(ph, x):
        return solve_states(neo_hookean, x, ph, TIGHT).require_ok()

    c = at(phi, grid)
    up, dn = at(phi + dphi, [l0]), at(phi - dphi, [l0])
    p_l = (c.p_hat[1] - c.p_hat[0]) / (2 * dl)
    v_l = (c.v_hat[1] - c.v_hat[0]) / (2 * dl)
    q_l = (c.q_hat[1] - c.q_hat[0]) / (2 * dl)
    p_phi = (up.p_hat[0] - dn.p_hat[0]) / (2 * dphi)
    v_phi = (up.v_hat[0] - dn.v_hat[0]) / (2 * dphi)
    dp_dphi_at_v = p_phi - p_l * v_phi / v_l
    dq_dv_at_phi = q_l / v_l
    assert dp_dphi_at_v == pytest.approx(-dq_dv_at_phi, rel=1e-5)


def test_charge_is_minus_voltage_derivative_of_potential(neo_hookean):
    """Q̂ = −∂Ψ̂/∂Φ̂ at fixed V̂ — equivalently at fixed λ0 corrected by p̂ ∂V̂/∂Φ̂."""
    l0, phi, d = 2.0, 0.1, 1e-4
    up, dn, mid = (solve_states(neo_hookean, [l0], ph, TIGHT) for ph in (phi + d, phi - d, phi))
    dpsi = (up.psi_hat[0] - dn.psi_hat[0]) / (2 * d)
    dv = (up.v_hat[0] - dn.v_hat[0]) / (2 * d)
    assert dpsi == pytest.approx(mid.p_hat[0] * dv - mid.q_hat[0], rel=1e-6)


def test_neo_hookean_pressure_maximum():
    """The neo-Hookean clamped membrane, no prestretch, no voltage: p̂max ≈ 1.879.

    The reference value 1.879 was computed independently of this project (the issue states it to
    four digits); the solver must land within its last digit.
    """
    curve = pressure_volume_curve(MembraneModel(NeoHookean()), 0.0, np.linspace(1.05, 3.5, 60))
    (lp,) = [lp for lp in curve.limit_points if lp.kind == "pressure_max"]
    assert lp.p_hat == pytest.approx(1.879, abs=5e-4)


def test_large_jlim_is_neo_hookean(neo_hookean):
    gent = MembraneModel(Gent(1e8))
    l0 = np.linspace(1.1, 3.5, 7)
    a, b = solve_states(neo_hookean, l0, 0.1), solve_states(gent, l0, 0.1)
    np.testing.assert_allclose(b.p_hat, a.p_hat, rtol=1e-6)
    np.testing.assert_allclose(b.v_hat, a.v_hat, rtol=1e-6)


@pytest.mark.parametrize("pre, tolerance", [(3.0, 3e-3), (5.0, 2e-4), (8.0, 1e-5)])
def test_large_prestretch_approaches_constant_tension(pre, tolerance):
    """A strongly prestretched membrane behaves as one of constant tension: p̂max → 2(1 − λpre⁻⁶)/λpre.

    The deviation shrinks fast with λpre (the extra stretch of inflation matters less and less);
    measured: 1.3e-3 at λpre = 3, 5.9e-5 at 5, 3.5e-6 at 8. The maximum sits where the pole
    stretch has doubled (a hemisphere).
    """
    model = MembraneModel(NeoHookean(), prestretch=pre)
    curve = pressure_volume_curve(model, 0.0, np.linspace(pre * 1.001, pre * 3, 80))
    (lp,) = [lp for lp in curve.limit_points if lp.kind == "pressure_max"]
    limit = 2 * (1 - pre**-6) / pre
    assert lp.p_hat == pytest.approx(limit, rel=tolerance)
    assert lp.p_hat > limit  # inflation adds stretch, so tension and pressure exceed the limit
    assert lp.pole_stretch / pre == pytest.approx(2.0, rel=3e-3)


def test_pole_series_start_does_not_matter(neo_hookean):
    """Moving the series hand-over radius by 10x changes nothing above the tolerance."""
    l0 = np.array([1.3, 2.2, 3.3])
    a = solve_states(neo_hookean, l0, 0.1, SolverSettings(rtol=1e-12, pole_radius=1e-4))
    b = solve_states(neo_hookean, l0, 0.1, SolverSettings(rtol=1e-12, pole_radius=1e-5))
    np.testing.assert_allclose(a.p_hat, b.p_hat, rtol=1e-10)


def test_wrinkling_is_reported_not_integrated(neo_hookean):
    """Voltage on a barely inflated membrane: the pole (or the meridian) wrinkles; no number is returned."""
    s = solve_states(neo_hookean, [1.01, 1.02, 2.0], 0.3)
    assert s.status[0] in (WRINKLED_AT_POLE, WRINKLED)
    assert s.status[2] == OK
    assert np.isnan(s.p_hat[0]) and np.isfinite(s.p_hat[2])
    with pytest.raises(ModelRangeError, match="wrinkl"):
        s.require_ok()


@pytest.mark.parametrize("l0", [1.0, 0.9, float("nan")])
def test_bad_pole_stretch(neo_hookean, l0):
    with pytest.raises(SceneError) as info:
        solve_states(neo_hookean, [l0], 0.0)
    assert info.value.field == "pole_stretch"


def test_negative_voltage_rejected(neo_hookean):
    with pytest.raises(SceneError) as info:
        solve_states(neo_hookean, [2.0], -0.1)
    assert info.value.field == "phi_hat"


def test_threads_sharing_a_model_get_the_states_of_one_thread():
    """Small batches run through preallocated buffers (:class:`coexist.numerics.buffers.BufferedFunction`); four
    threads shooting the same model at once must each get exactly what one thread alone gets (a lock makes every
    buffered call atomic). Asserted: equal to the last bit."""
    import threading

    from coexist.effects import Gent

    model = MembraneModel(elasticity=Gent(97.0))
    settings = SolverSettings()
    jobs = [(np.linspace(1.2 + 0.1 * k, 2.5 + 0.1 * k, 3), 0.05 * k) for k in range(4)]
    alone = [solve_states(model, l0, phi, settings, derivatives=True) for l0, phi in jobs]
    results: dict = {}

    def run(k):
        for _ in range(20):
            results[k] = solve_states(model, jobs[k][0], jobs[k][1], settings, derivatives=True)

    import sys

    interval = sys.getswitchinterval()
    sys.setswitchinterval(1e-6)  # switch threads as often as possible: a race would show
    try:
        threads = [threading.Thread(target=run, args=(k,)) for k in range(4)]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
    finally:
        sys.setswitchinterval(interval)
    for k in range(4):
        np.testing.assert_array_equal(results[k].p_hat, alone[k].p_hat)
        np.testing.assert_array_equal(results[k].derivatives.dv_dl0, alone[k].derivatives.dv_dl0)
