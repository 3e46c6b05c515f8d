"""Patterned and layered zones (:mod:`coexist.patterned`): limits, interfaces, identities, a second method, hard cases.

The second method is a multipoint boundary value problem solved by collocation
(:func:`scipy.integrate.solve_bvp`), built from the hand-derived neo-Hookean equations of
``tests/test_second_method.py`` (not from :mod:`coexist.model` nor from the shooting): one copy of the
seven membrane rows per region on ``t ∈ [0, 1]`` (``R̂ = ak + t (bk − ak)``), the pressure ``p̂`` as unknown
parameter, the pole series at ``R̂ = ε``, at every interface ``λ2, θ, V̂, Q̂, Ψ̂, ẑ`` and the force
``n T̂1`` continuous, ``λ2 = 1`` at the clamp. Region ``k`` of ``nk`` layers uses ``p̂/nk`` and ``Φ̂/nk`` (0
without electrode) and carries ``nk`` times the one-layer free energy.
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import TIGHT
from scipy.integrate import solve_bvp
from test_second_method import membrane_rhs, pole_series, spherical_cap_guess, tensions

from coexist import pressure_volume_curve, solve_states
from coexist.errors import ModelRangeError, SceneError
from coexist.model import MembraneModel
from coexist.patterned import (
    PatternedStates,
    Region,
    ZonePattern,
    interface_stretch,
    patterned_pressure_volume_curve,
    solve_patterned_states,
)
from coexist.shooting import OK, WRINKLED

#: the neo-Hookean snap-through pressures of a uniform zone (README, tests/test_curves)
P_MAX_PHI_01 = 1.81362361
P_MAX_PASSIVE = 1.87917347
#: a uniform zone cut into three identical regions: the patterned machinery (interfaces, the Newton iteration
#: on the interface scale) with nothing to jump
SPLIT = ZonePattern(((0.3, 1, True), (0.7, 1, True), (1.0, 1, True)))
POLE_STRETCHES = np.linspace(1.05, 3.8, 12)


@pytest.fixture(scope="module")
def model():
    return MembraneModel()


# --- the pattern ----------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "regions, field",
    [
        ((), "pattern.regions"),
        (((0.5, 1, True), (0.4, 1, False), (1.0, 1, True)), "pattern.regions[1].outer"),
        (((0.5, 1, True), (0.9, 1, False)), "pattern.regions[1].outer"),
        (((0.0, 1, True), (1.0, 1, False)), "pattern.regions[0].outer"),
        (((0.5, 0, True), (1.0, 1, False)), "pattern.regions[0].layers"),
        (((0.5, 1.5, True), (1.0, 1, False)), "pattern.regions[0].layers"),
        (((0.5, 1, "yes"), (1.0, 1, False)), "pattern.regions[0].electrode"),
        (((0.5, 1), (1.0, 1, False)), "pattern.regions[0]"),
    ],
)
def test_bad_patterns_name_the_field(regions, field):
    with pytest.raises(SceneError) as err:
        ZonePattern(regions)
    assert err.value.field == field


def test_constructors():
    assert ZonePattern.inner_circle(0.4, passive_layers=2).regions == (
        Region(0.4, 1, True),
        Region(1.0, 2, False),
    )
    assert ZonePattern.ring(0.2, 0.6).interfaces == (0.2, 0.6)
    assert ZonePattern.ring(0.2, 1.0).interfaces == (0.2,)
    assert ZonePattern.inner_circle(1.0) == ZonePattern.full()
    assert ZonePattern.ring(0.2, 0.6).electrode_area_fraction == pytest.approx(0.36 - 0.04, abs=1e-15)
    with pytest.raises(SceneError, match="ring_outer"):
        ZonePattern.ring(0.6, 0.2)
    with pytest.raises(SceneError, match="inner_fraction"):
        ZonePattern.inner_circle(1.5)
    with pytest.raises(SceneError, match="pattern"):
        solve_patterned_states(MembraneModel(), "inner-circle", [2.0], 0.1)


# --- limits ------------------------------------------------------------------------------------------------


def test_one_region_patterns_are_the_uniform_zone(model):
    """One region of n layers is solve_states at p̂/n, Φ̂/n: 1 layer exactly, 2 layers twice p̂ and Ψ̂."""
    uniform = solve_states(model, POLE_STRETCHES, 0.1)
    full = solve_patterned_states(model, ZonePattern.full(), POLE_STRETCHES, 0.1)
    for name in ("p_hat", "v_hat", "q_hat", "psi_hat", "apex_height", "min_tension"):
        np.testing.assert_array_equal(getattr(full, name), getattr(uniform, name))
    double = solve_patterned_states(model, ZonePattern.full(layers=2), POLE_STRETCHES, 0.2)
    np.testing.assert_allclose(double.p_hat, 2 * uniform.p_hat, rtol=1e-15)
    np.testing.assert_allclose(double.psi_hat, 2 * uniform.psi_hat, rtol=1e-15)
    np.testing.assert_array_equal(double.q_hat, uniform.q_hat)  # charge per area q̂(Φ̂/n): no factor
    passive = solve_patterned_states(model, ZonePattern.no_electrode(), POLE_STRETCHES, 0.3)
    np.testing.assert_array_equal(passive.p_hat, solve_states(model, POLE_STRETCHES, 0.0).p_hat)
    assert np.all(passive.q_hat == 0)


def test_split_uniform_zone_reproduces_solve_states(model):
    """The general path (two interfaces, nothing to jump) gives solve_states to 1e-9 (measured 2e-12 at
    rtol 1e-12: p̂ 2.2e-13, V̂ 4.3e-13, Q̂ 2.9e-13, Ψ̂ 2.0e-12, ẑ 3.9e-13)."""
    split = solve_patterned_states(model, SPLIT, POLE_STRETCHES, 0.1, TIGHT)
    uniform = solve_states(model, POLE_STRETCHES, 0.1, TIGHT)
    assert np.all(split.ok)
    for name in ("p_hat", "v_hat", "q_hat", "psi_hat", "apex_height", "min_tension"):
        np.testing.assert_allclose(getattr(split, name), getattr(uniform, name), rtol=1e-9, err_msg=name)
    np.testing.assert_allclose(split.clamp_radius, np.exp(np.log(split.clamp_radius)), rtol=0)


def test_two_layers_everywhere_carry_twice_the_pressure(model):
    """Two layers everywhere (general path) at Φ̂ = 0.2 = one layer at 0.1 with twice p̂, same V̂ (1e-9;
    measured 6e-13)."""
    two = ZonePattern(((0.4, 2, True), (1.0, 2, True)))
    a = solve_patterned_states(model, two, POLE_STRETCHES, 0.2, TIGHT)
    b = solve_states(model, POLE_STRETCHES, 0.1, TIGHT)
    np.testing.assert_allclose(a.p_hat, 2 * b.p_hat, rtol=1e-9)
    np.testing.assert_allclose(a.v_hat, b.v_hat, rtol=1e-9)
    np.testing.assert_allclose(a.psi_hat, 2 * b.psi_hat, rtol=1e-9)


def test_limit_points_of_the_limits(model):
    """Full electrode: p̂max 1.81362361 at Φ̂ = 0.1; no electrode at Φ̂ = 0.1, and patterns at Φ̂ = 0 (general
    path): the passive 1.87917347 (1e-8 against the uniform curves; measured 1e-14)."""
    passive = pressure_volume_curve(model, 0.0, settings=TIGHT).limit_points[0].p_hat
    active = pressure_volume_curve(model, 0.1, settings=TIGHT).limit_points[0].p_hat
    assert active == pytest.approx(P_MAX_PHI_01, abs=1e-8)
    assert passive == pytest.approx(P_MAX_PASSIVE, abs=1e-8)
    cases = [
        (ZonePattern.full(), 0.1, active),
        (SPLIT, 0.1, active),
        (ZonePattern.no_electrode(), 0.1, passive),
        (ZonePattern.inner_circle(0.5), 0.0, passive),
        (ZonePattern.ring(0.3, 0.7), 0.0, passive),
    ]
    for pattern, phi, expected in cases:
        curve = patterned_pressure_volume_curve(model, pattern, phi, settings=TIGHT)
        assert curve.limit_points[0].kind == "pressure_max"
        assert curve.limit_points[0].p_hat == pytest.approx(expected, abs=1e-8), pattern.describe()


# --- interfaces --------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "pattern, phi",
    [(ZonePattern.inner_circle(0.5, passive_layers=2), 0.2), (ZonePattern.ring(0.3, 0.7), 0.25)],
)
def test_interfaces_are_continuous_and_at_their_fractions(model, pattern, phi):
    """At every interface: R̂ at its fraction of the clamp radius, r̂, ẑ, θ and the force n T̂1 continuous
    (1e-10), and λ1 jumps (the layers or the field change there)."""
    st = solve_patterned_states(model, pattern, [1.4, 2.0, 2.6], phi, TIGHT)
    assert isinstance(st, PatternedStates) and np.all(st.ok)
    edges = st.interfaces  # (state, interface, side, (R, r, z, θ, N))
    assert edges.shape == (3, len(pattern.interfaces), 2, 5)
    for k, fraction in enumerate(pattern.interfaces):
        np.testing.assert_allclose(edges[:, k, :, 0], fraction, rtol=1e-10)
    for q in range(1, 5):
        np.testing.assert_allclose(edges[:, :, 0, q], edges[:, :, 1, q], rtol=1e-10, atol=1e-12)
    # the meridional stretch does jump: recover λ1 on both sides from the force
    lam2 = edges[:, 0, 0, 1] / edges[:, 0, 0, 0]
    assert np.all(np.isfinite(lam2))


def test_interface_stretch_balances_the_force(model):
    """n⁻T̂1(λ1⁻) = n⁺T̂1(λ1⁺) to 1e-13 on the stable branch, equal sides unchanged, and no root past the
    outer side's instability."""
    l1, l2 = np.array([1.2, 1.8, 2.5, 3.0]), np.array([1.1, 1.6, 2.0, 2.2])
    out, ok = interface_stretch(model, l1, l2, 0.2, 1.0, 0.0, 2.0)
    assert np.all(ok)
    T_in = model.tensions(l1, l2, 0.2)[0]
    T_out, _, T11, _ = model.tensions(out, l2, 0.0)[:4]
    np.testing.assert_allclose(2 * T_out, T_in, rtol=1e-13)
    assert np.all(T11 > 0)
    same, ok = interface_stretch(model, l1, l2, 0.1, 1.0, 0.1, 1.0)
    np.testing.assert_array_equal(same, l1)
    # a passive stack pulling an electroded layer whose meridional tension has no positive value at this hoop
    # stretch (Φ̂λ2 > 1): no stable root, NaN
    bad, ok = interface_stretch(model, np.array([3.0]), np.array([3.0]), 0.0, 2.0, 0.4, 1.0)
    assert not ok[0] and np.isnan(bad[0])


# --- identities --------------------------------------------------------------------------------------------


def _chebyshev_nodes(a, b, n):
    k = np.arange(n)
    return np.sort(0.5 * (a + b) + 0.5 * (b - a) * np.cos(np.pi * (k + 0.5) / n))


def test_work_of_the_pressure_is_the_potential(model):
    """Along a patterned curve at fixed Φ̂: ∫ p̂ dV̂ = Ψ̂(b) − Ψ̂(a), by Chebyshev interpolation of p̂(λ0) and
    V̂(λ0) on 28 nodes (1e-10; measured 9e-15)."""
    pattern = ZonePattern.inner_circle(0.5, passive_layers=2)
    a, b = 1.3, 2.6
    x = _chebyshev_nodes(a, b, 28)
    st = solve_patterned_states(model, pattern, np.concatenate([[a, b], x]), 0.2, TIGHT)
    assert np.all(st.ok)
    cheb = np.polynomial.Chebyshev
    p = cheb.fit(x, st.p_hat[2:], 27, domain=[a, b])
    v = cheb.fit(x, st.v_hat[2:], 27, domain=[a, b])
    work = (p * v.deriv()).integ(lbnd=a)(b)
    assert work == pytest.approx(st.psi_hat[1] - st.psi_hat[0], rel=1e-10)


def test_maxwell_relation_with_the_charge_on_the_electrode_only(model):
    """∂Ψ̂/∂Φ̂|λ0 = p̂ ∂V̂/∂Φ̂ − Q̂ (dΨ̂ = p̂ dV̂ − Q̂ dΦ̂) with Q̂ over the electrode only, by fourth-order central
    differences in Φ̂ (h = 2e-3; 1e-8 relative to Q̂, measured 3.6e-10). A charge counted over the passive
    annulus too would miss by far more (the stretched annulus is three quarters of the reference area)."""
    pattern = ZonePattern.inner_circle(0.5)
    l0, phi, h = 1.9, 0.2, 2e-3
    phis = phi + h * np.array([-2, -1, 0, 1, 2])
    st = solve_patterned_states(model, pattern, np.full(5, l0), phis, TIGHT)
    assert np.all(st.ok)

    def d(y):
        return (y[0] - 8 * y[1] + 8 * y[3] - y[4]) / (12 * h)

    lhs = d(st.psi_hat)
    rhs = st.p_hat[2] * d(st.v_hat) - st.q_hat[2]
    assert lhs == pytest.approx(rhs, abs=1e-8 * st.q_hat[2])


# --- a second method: multipoint collocation -----------------------------------------------------------------

POLE_RADIUS = 3e-4
BVP_TOL = 1e-9


def solve_patterned_bvp(pattern, l0, phi, nodes=60):
    """The patterned zone at pole stretch ``λ0`` by multipoint collocation (module docstring)."""
    K = len(pattern.regions)
    bounds = [POLE_RADIUS] + [r.outer for r in pattern.regions]
    n = [float(r.layers) for r in pattern.regions]
    ph = [phi / r.layers if r.electrode else 0.0 for r in pattern.regions]
    t = np.linspace(0.0, 1.0, nodes)
    guesses, p_guess = [], 0.0
    for k in range(K):
        radius = bounds[k] + t * (bounds[k + 1] - bounds[k])
        y, p = spherical_cap_guess(l0, ph[k], None, radius)
        guesses.append(y)
        p_guess += n[k] * p * (bounds[k + 1] ** 2 - bounds[k] ** 2)
    y0 = np.vstack(guesses)

    def fun(t, y, params):
        out = np.empty_like(y)
        for k in range(K):
            width = bounds[k + 1] - bounds[k]
            radius = bounds[k] + t * width
            rates = membrane_rhs(radius, y[7 * k : 7 * k + 7], params[0] / n[k], ph[k], None)
            rates[5] *= n[k]  # n layers carry n times the one-layer free energy at Φ̂/n
            out[7 * k : 7 * k + 7] = width * rates
        return out

    def bc(ya, yb, params):
        p = params[0]
        start = pole_series(l0, p / n[0], ph[0], None, POLE_RADIUS)
        start[5] *= n[0]
        res = [ya[:7] - start]
        for k in range(K - 1):
            left, right = yb[7 * k : 7 * k + 7], ya[7 * k + 7 : 7 * k + 14]
            force = n[k] * tensions(left[0], left[1], ph[k])[0] - n[k + 1] * tensions(right[0], right[1], ph[k + 1])[0]
            res.append(np.concatenate([[force], right[1:] - left[1:]]))
        res.append([yb[7 * (K - 1) + 1] - 1.0])
        return np.concatenate(res)

    with np.errstate(all="ignore"):
        sol = solve_bvp(fun, bc, t, y0, p=[p_guess], tol=BVP_TOL, bc_tol=1e-13, max_nodes=200_000)
    assert sol.status == 0, sol.message
    end = sol.y[7 * (K - 1) :, -1]
    return {"p_hat": sol.p[0], "v_hat": end[3], "q_hat": end[4], "psi_hat": end[5], "apex_height": end[6]}


@pytest.mark.parametrize(
    "pattern, phi, l0",
    [
        (ZonePattern.inner_circle(0.5, passive_layers=2), 0.2, 1.8),
        (ZonePattern.ring(0.3, 0.7), 0.25, 2.2),
    ],
    ids=["inner-circle-two-layers", "ring"],
)
def test_multipoint_bvp_agrees_with_the_shooting(model, pattern, phi, l0):
    """Collocation (tol 1e-9, ε = 3e-4) and shooting (rtol 1e-12) agree to 1e-9 (relative; measured at most
    3.3e-13 over p̂, V̂, Q̂, Ψ̂, ẑ in both cases)."""
    bvp = solve_patterned_bvp(pattern, l0, phi)
    st = solve_patterned_states(model, pattern, [l0], phi, TIGHT)
    assert st.status[0] == OK
    for name, rel in (("p_hat", 1e-9), ("v_hat", 1e-9), ("q_hat", 1e-9), ("psi_hat", 1e-9), ("apex_height", 1e-9)):
        assert getattr(st, name)[0] == pytest.approx(bvp[name], rel=rel), name


# --- hard cases --------------------------------------------------------------------------------------------


def test_low_inflation_under_voltage_wrinkles_at_the_electrode_edge(model):
    """Φ̂ = 0.3, electrode disc of half the radius: at λ0 = 1.0192 the passive annulus holds the active disc
    back and the hoop tension on the electrode side of its edge is negative (−7.5e-4 μH): WRINKLED with the
    reason, never a state; at λ0 = 1.0218 the zone is taut (smallest tension 0.0133 μH)."""
    pattern = ZonePattern.inner_circle(0.5)
    st = solve_patterned_states(model, pattern, [1.0192, 1.0218], 0.3)
    assert st.status[0] == WRINKLED and st.status[1] == OK
    assert np.isnan(st.p_hat[0]) and st.min_tension[1] > 0
    detail = st.failure_detail[0]
    assert "hoop tension" in detail and "region 1 (electrode" in detail and "edge at R/A = 0.5" in detail
    assert "-0.0007488" in detail
    assert st.min_tension[1] == pytest.approx(0.0133227, rel=1e-5)
    assert st.fail_radius[0] == pytest.approx(0.5, abs=1e-9)
    with pytest.raises(ModelRangeError, match="hoop tension") as err:
        st.require_ok()
    assert err.value.reason == "wrinkling"
    curve = patterned_pressure_volume_curve(model, pattern, 0.3, pole_stretch=np.linspace(1.017, 1.2, 12))
    assert curve.starts_because.startswith("wrinkling")
    assert np.all(curve.states.min_tension > 0)


def test_a_small_active_spot_snaps_through_locally(model):
    """Under voltage a shrinking electrode does not tend to the passive curve. At Φ̂ = 0.4 the pressure maximum
    of an electrode disc of radius fA is 1.5512 (f = 0.05) and 1.5827 (f = 0.025): converging (by 0.032, then
    0.011) to about 1.60, far below the passive 1.8792 (and above the fully covered zone's 1.0374). At the
    maximum the spot's pole stretch (~2.1) is past the stretch ~1.63 of its largest equibiaxial tension: the
    soft active spot bulges out of the passive membrane on its own."""
    passive = pressure_volume_curve(model, 0.0).limit_points[0].p_hat
    full = pressure_volume_curve(model, 0.4).limit_points[0].p_hat
    maxima = {}
    for f in (0.05, 0.025):
        curve = patterned_pressure_volume_curve(model, ZonePattern.inner_circle(f), 0.4)
        first = curve.limit_points[0]
        assert first.kind == "pressure_max"
        maxima[f] = (first.p_hat, first.pole_stretch)
    assert maxima[0.05][0] == pytest.approx(1.5512, abs=2e-4)
    assert maxima[0.025][0] == pytest.approx(1.5827, abs=2e-4)
    assert passive - maxima[0.025][0] > 0.25  # not the passive curve
    assert maxima[0.025][0] - full > 0.5  # nor the uniformly covered one
    assert maxima[0.025][0] - maxima[0.05][0] < 0.05
    for _, l0 in maxima.values():
        assert 2.0 < l0 < 2.2
    # the spot is on the falling side of its own equibiaxial tension T̂(λ; 0.4) there
    lam = np.linspace(1.0, 3.0, 2001)
    peak = lam[np.argmax(model.tensions(lam, lam, 0.4)[0])]
    assert peak == pytest.approx(1.63, abs=0.01)
    assert maxima[0.025][1] > peak + 0.3


#: the built-in inner-circle scene's wrinkling state: the formally continued ramp's range end (Gent 97, an electrode
#: disc of half the radius in a two-layer passive annulus), where the stack's hoop tension has its minimum inside
#: a step of the pole region (R ≈ 0.04 of the trial membrane)
WRINKLING_POLE_STRETCH = 5.791210887591717
WRINKLING_PHI = 0.2651180918430448


def test_the_smallest_tension_of_a_patterned_state_is_a_smooth_function():
    """The smallest stack tension of formally continued patterned states: a tension's minimum inside a step is
    located exactly (the root of ``dT/dR̂`` by re-taking the step, as for uniform zones), so at 5 pole stretches
    within ±1e-4 of the inner-circle scene's wrinkling state its values lie on a quadratic to 1e-9 (measured
    3e-13; the cubic Hermite estimate between nodes, before, 9e-6), they do not depend on the tolerance
    (rtol 1e-10 against 1e-12: 1e-9, measured 6e-11) nor on the batch (the same states among 300, whose first
    passes run on the numpy integrator and whose last, of about 150 states, on the compiled attempt functions:
    1e-9, measured 2e-12)."""
    from coexist.model import build_model

    gent = build_model("gent", jlim=97.0, voltage=True)
    pattern = ZonePattern.inner_circle(0.5, passive_layers=2)
    d = np.linspace(-1e-4, 1e-4, 5)
    l0 = WRINKLING_POLE_STRETCH + d
    st = solve_patterned_states(gent, pattern, l0, WRINKLING_PHI, formal=True)
    assert np.all(st.status == OK), st.failure_detail
    T = st.min_tension
    # it crosses zero here: the ramp's wrinkling event is its root
    assert T[0] > 0 > T[-1]
    fit = np.polyval(np.polyfit(d, T, 2), d)
    assert np.max(np.abs(fit - T)) < 1e-9, T
    tight = solve_patterned_states(gent, pattern, l0, WRINKLING_PHI, TIGHT, formal=True)
    np.testing.assert_allclose(tight.min_tension, T, rtol=0, atol=1e-9)
    many = np.concatenate([l0, np.linspace(l0[0] - 0.01, l0[-1] + 0.01, 295)])
    big = solve_patterned_states(gent, pattern, many, WRINKLING_PHI, formal=True)
    np.testing.assert_allclose(big.min_tension[:5], T, rtol=0, atol=1e-9)


def test_the_patterned_wrinkling_event_is_located_like_a_uniform_one():
    """The built-in inner-circle ramp (default settings, its errors measured by locating every transition again at
    rtol/100): the zone leaves the model's range where the hoop tension of the pole region vanishes, at
    4.359049666 kV with an error below 1e-7 kV (measured 5e-9, as its fold's; 5e-5 and then 7e-6 when the
    minimum inside a step was the Hermite estimate)."""
    from coexist.scene import builtin_scene_text, parse_scene
    from coexist.simulation import Simulation

    sim = Simulation.from_scene(parse_scene(builtin_scene_text("inner-circle")))
    report = sim.ramp()
    (up,) = [t for t in report.result.transitions if t.kind == "no_stable_state" and t.direction == "up"]
    assert up.measured
    assert report.voltage_kV(up.phi_hat_error) < 1e-7, report.voltage_kV(up.phi_hat_error)
    assert report.voltage_kV(up.phi_hat) == pytest.approx(4.359049666, rel=0, abs=2e-9)
