"""Tension-field states in the vectorised shooting (coexist.wrinkling, issue 12 step 3).

Checks that can fail: the relaxed model equals the taut one where both tensions are positive; its
wrinkled states equal an independent integration of the same equations (scipy's DOP853 with located
events, coexist.studies.wrinkled_shooting, itself checked against the IPOPT minimisation of the relaxed
energy in tests/test_wrinkled_reference.py); the exact derivatives equal difference quotients; the
identities ∫p̂ dV̂ = ΔΨ̂ and ∂p̂/∂Φ̂|V̂ = −∂Q̂/∂V̂|Φ̂ hold through wrinkled segments; wrinkling starts where
the taut model's smallest tension crosses zero; a flat prestretched membrane loses its tension at
Φ̂ = √(λpre⁻² − λpre⁻⁸).
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import brentq

from coexist import SceneError
from coexist.curves import pressure_volume_curve
from coexist.model import build_model
from coexist.scene import parse_scene
from coexist.settings import SolverSettings
from coexist.shooting import OK, PULL_IN, WRINKLED, WRINKLED_AT_POLE, reason_tag, solve_states
from coexist.studies.wrinkled_shooting import shoot_relaxed as scipy_relaxed

TIGHT = SolverSettings(rtol=1e-12)
MATERIALS = {"neo-hookean": ("neo-hookean", None), "gent": ("gent", 97)}


def relaxed(key, prestretch=1.0):
    material, jlim = MATERIALS[key]
    return build_model(material, jlim, prestretch=prestretch, wrinkling="tension-field")


def taut(key, prestretch=1.0):
    material, jlim = MATERIALS[key]
    return build_model(material, jlim, prestretch=prestretch)


@pytest.mark.parametrize("key", list(MATERIALS))
@pytest.mark.parametrize("phi", [0.0, 0.1, 0.25])
def test_taut_states_are_unchanged(key, phi):
    """Where both tensions are positive the tension-field model gives the taut model's states to the solver
    tolerance (the same equations; the two models' integrators may run in CasADi's virtual machine or
    compiled, whose roundoff can change an accepted step), and only the states the taut model refuses as
    wrinkled change."""
    l0 = np.concatenate([np.linspace(1.005, 1.05, 20), np.linspace(1.06, 3.5, 40)])
    a = solve_states(taut(key), l0, phi, derivatives=True)
    b = solve_states(relaxed(key), l0, phi, derivatives=True)
    ok = a.ok
    assert ok.sum() > 40
    for name in ("p_hat", "v_hat", "q_hat", "psi_hat", "apex_height", "min_tension"):
        np.testing.assert_allclose(getattr(b, name)[ok], getattr(a, name)[ok], rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(b.derivatives.dp_dl0[ok], a.derivatives.dp_dl0[ok], rtol=1e-8, atol=1e-10)
    assert np.all(b.wrinkled_fraction[ok] == 0.0)
    changed = a.status != b.status
    assert set(a.status[changed]) <= {WRINKLED}
    if phi > 0.2:  # the voltage wrinkles the barely inflated membrane near its clamp: those states now exist
        assert (a.status == WRINKLED).any() and np.all(b.status[a.status == WRINKLED] == OK)


#: wrinkled states: barely inflated under voltage (wrinkled from R̂ ≈ 0.7–0.9 to the clamp) and, Gent only,
#: on the re-stiffened branch (wrinkled from R̂ ≈ 0.3–0.5 to the clamp)
WRINKLED_CASES = [(k, l0, phi) for k in MATERIALS for l0, phi in ((1.02, 0.3), (1.03, 0.3), (1.015, 0.2))] + [
    ("gent", 6.3, 0.3),
    ("gent", 6.7, 0.4),
]


@pytest.mark.parametrize("key, l0, phi", WRINKLED_CASES)
def test_wrinkled_states_equal_an_independent_integration(key, l0, phi):
    """The vectorised relaxed shooting (numpy/CasADi DOP853, switches located inside the step) against
    scipy's solve_ivp with its own event location, both at rtol 1e-12: p̂, V̂, Q̂, Ψ̂, the apex and the
    wrinkled interval agree to 1e-9."""
    ours = solve_states(relaxed(key), np.array([l0]), phi, TIGHT)
    ref = scipy_relaxed(taut(key), l0, phi, rtol=1e-12)
    assert ref.status == "ok" and ours.status[0] == OK
    assert ref.wrinkled_radii, "the case must be wrinkled"
    for name in ("p_hat", "v_hat", "q_hat", "psi_hat", "apex_height"):
        assert getattr(ours, name)[0] == pytest.approx(getattr(ref, name), rel=1e-9), name
    ours_radii = np.array(ours.wrinkled_radii[0])
    np.testing.assert_allclose(ours_radii, np.array(ref.wrinkled_radii), rtol=1e-9)
    assert ours.wrinkled_fraction[0] == pytest.approx(ref.wrinkled_fraction, rel=1e-9)
    assert ours.min_tension[0] == 0.0


@pytest.mark.parametrize("key", list(MATERIALS))
def test_exact_derivatives_through_switches(key):
    """The variational equations with the saltation at every switch give the derivatives of the wrinkled
    states: equal to Richardson-extrapolated central differences to 1e-7."""
    model = relaxed(key)
    cases = [(a, b) for k, a, b in WRINKLED_CASES if k == key]
    l0 = np.array([c[0] for c in cases])
    phi = np.array([c[1] for c in cases])
    s = solve_states(model, l0, phi, TIGHT, derivatives=True)
    assert s.ok.all() and all(s.wrinkled_radii)

    def central(name, along, d):
        dl, dp = (d, 0.0) if along == "l0" else (0.0, d)
        hi = getattr(solve_states(model, l0 + dl, phi + dp, TIGHT), name)
        lo = getattr(solve_states(model, l0 - dl, phi - dp, TIGHT), name)
        return (hi - lo) / (2 * d)

    for along in ("l0", "phi"):
        for q in ("p", "v", "q"):
            d = 2e-4
            fd = (4 * central(f"{q}_hat", along, d / 2) - central(f"{q}_hat", along, d)) / 3
            exact = getattr(s.derivatives, f"d{q}_d{along}")
            np.testing.assert_allclose(exact, fd, rtol=1e-7, atol=1e-9, err_msg=f"d{q}_d{along}")


def _onset(model_taut, phi, lo, hi):
    """The pole stretch where the taut model's smallest tension crosses zero (formal states)."""
    return brentq(
        lambda x: solve_states(model_taut, np.array([x]), phi, TIGHT, formal=True).min_tension[0], lo, hi, xtol=1e-13
    )


@pytest.mark.parametrize("key", list(MATERIALS))
def test_identities_hold_through_wrinkled_states(key):
    """Along the curve at Φ̂ = 0.25, from wrinkled states through the onset to taut ones:
    ∫p̂ dV̂ = ΔΨ̂ (Gauss–Legendre on each side of the onset, where the curve is smooth) to 1e-9 of ΔΨ̂,
    and the Maxwell relation ∂p̂/∂Φ̂|V̂ = −∂Q̂/∂V̂|Φ̂ to 1e-8 at every node."""
    model, phi = relaxed(key), 0.25
    onset = _onset(taut(key), phi, 1.02, 1.2)
    a, b = 1.012, 1.3
    total, nodes = 0.0, []
    for lo, hi in ((a, onset), (onset, b)):
        x, w = np.polynomial.legendre.leggauss(24)
        l0 = 0.5 * (hi - lo) * x + 0.5 * (hi + lo)
        s = solve_states(model, l0, phi, TIGHT, derivatives=True)
        assert s.ok.all()
        total += 0.5 * (hi - lo) * np.sum(w * s.p_hat * s.derivatives.dv_dl0)
        nodes.append(s)
    assert nodes[0].wrinkled_fraction.min() > 0 and np.all(nodes[1].wrinkled_fraction == 0)
    ends = solve_states(model, np.array([a, b]), phi, TIGHT)
    dpsi = ends.psi_hat[1] - ends.psi_hat[0]
    assert total == pytest.approx(dpsi, rel=1e-9)
    for s in nodes:
        d = s.derivatives
        dp_dphi_at_v = d.dp_dphi - d.dp_dl0 * d.dv_dphi / d.dv_dl0
        dq_dv_at_phi = d.dq_dl0 / d.dv_dl0
        np.testing.assert_allclose(dp_dphi_at_v, -dq_dv_at_phi, rtol=1e-8, atol=1e-10)


@pytest.mark.parametrize("key", list(MATERIALS))
def test_wrinkling_starts_where_the_taut_tension_crosses_zero(key):
    """Below the onset λ0* (the root of the taut model's smallest tension) the relaxed states are wrinkled,
    with a region that shrinks to nothing at λ0*; above it they are taut. p̂ is continuous there (the
    difference across λ0* ± ε falls like ε)."""
    model, phi = relaxed(key), 0.3
    onset = _onset(taut(key), phi, 1.03, 1.3)
    eps = np.array([1e-3, 1e-4, 1e-5])
    below = solve_states(model, onset - eps, phi, TIGHT)
    above = solve_states(model, onset + eps, phi, TIGHT)
    assert below.ok.all() and above.ok.all()
    frac = below.wrinkled_fraction
    assert np.all(frac > 0) and np.all(np.diff(frac) < 0)
    assert frac[-1] < 1e-2 * frac[0]  # the region closes as λ0 → λ0*
    assert np.all(above.wrinkled_fraction == 0) and np.all(above.min_tension > 0)
    gap = below.p_hat - above.p_hat  # O(ε) when p̂(λ0) is continuous at λ0*, O(1) if it jumped
    assert abs(gap[-1]) < 0.02 * abs(gap[0])


@pytest.mark.parametrize("prestretch", [1.2, 1.5, 2.0, 3.0])
def test_flat_prestretched_membrane_loses_tension(prestretch):
    """A flat neo-Hookean membrane with equibiaxial prestretch λpre loses its tension at
    Φ̂c = √(λpre⁻² − λpre⁻⁸): the model's tension vanishes there, a barely inflated membrane is taut just
    below Φ̂c and has no taut pole just above it (the pole would be slack)."""
    crit = np.sqrt(prestretch**-2 - prestretch**-8)
    model = relaxed("neo-hookean", prestretch)
    assert model.pole(prestretch, crit)[0] == pytest.approx(0.0, abs=1e-13)
    l0 = np.array([prestretch * (1 + 1e-3)])
    under = solve_states(model, l0, 0.995 * crit)
    over = solve_states(model, l0, 1.005 * crit)
    assert under.status[0] == OK and under.min_tension[0] > 0
    assert over.status[0] == WRINKLED_AT_POLE


def test_pull_in_of_a_wrinkled_segment_is_named():
    """In the default scene's bulged zone at 4.34 kV the wrinkled segment's tension T̂1(λ1) along the natural
    width would have to fall (K ≤ 0): the state is refused as electromechanical instability, not returned."""
    model = relaxed("gent")
    s = solve_states(model, np.array([6.0]), 0.2637158945860278)
    assert s.status[0] == PULL_IN and reason_tag(s.status[0]) == "electromechanical_instability"
    assert np.isnan(s.p_hat[0])


def test_a_curve_continues_through_wrinkled_states():
    """The p̂–V̂ curve of the tension-field model at Φ̂ = 0.2 starts at the first pole stretch (the taut model
    starts only above its wrinkling onset) and has the same pressure maximum."""
    model_t, model_r = taut("gent"), relaxed("gent")
    ct = pressure_volume_curve(model_t, phi_hat=0.2)
    cr = pressure_volume_curve(model_r, phi_hat=0.2)
    assert ct.starts_because and "wrinkling" in ct.starts_because
    assert cr.starts_because is None and cr.states.pole_stretch[0] < ct.states.pole_stretch[0]
    assert np.nanmax(cr.states.wrinkled_fraction) > 0.1
    assert cr.limit_points[0].p_hat == pytest.approx(ct.limit_points[0].p_hat, rel=1e-10)


def test_scene_field():
    """``[membrane] wrinkling`` selects the effect; a wrong value names the field."""
    base = (
        '[membrane]\nmaterial = "neo-hookean"\nshear_modulus_kPa = 45\nrelative_permittivity = 4.7\n'
        "thickness_mm = 0.5\nzone_radius_mm = 10\n{}\n[zones]\ncount = 1\npressure_mbar = 10\n"
    )
    scene = parse_scene(base.format('wrinkling = "tension-field"'))
    assert "wrinkling:tension-field" in scene.effects()
    assert scene.model().tension_field and "wrinkling:tension-field" in scene.model().effects
    assert not parse_scene(base.format("")).model().tension_field
    with pytest.raises(SceneError, match=r"wrinkling.*tension-field"):
        parse_scene(base.format('wrinkling = "tension field"'))


def test_paper_scene_with_tension_field_ends_by_pull_in():
    """The README's claim: the paper's scene (``wrinkling = "tension-field"``) follows the bulged zone past the
    taut model's end (4.331806 kV, its hoop tension reaching zero) and loses it at 4.336628993 kV (measured
    error 4.6e-9 kV), where the wrinkled zone pulls in (electromechanical instability); the transitions below are the
    taut model's."""
    from coexist.scene import builtin_scene_text
    from coexist.simulation import simulate_ramp

    report = simulate_ramp(parse_scene(builtin_scene_text("tricircle")))
    by_kind = {(t.kind, t.direction): t for t in report.result.transitions}
    end = by_kind[("no_stable_state", "up")]
    assert report.voltage_kV(end.phi_hat) == pytest.approx(4.336628993, abs=1e-6)
    assert report.voltage_kV(end.phi_hat_error) < 1e-8
    assert "electromechanical_instability" in end.reason + " ".join(report.result.notes)
    assert report.voltage_kV(by_kind[("spinodal", "up")].phi_hat) == pytest.approx(3.900030858, abs=2e-8)
    assert report.voltage_kV(by_kind[("spinodal", "down")].phi_hat) == pytest.approx(3.549240820, abs=2e-8)


# --- the fast path (issue 12's speed target): the restart at the taut shot's last node, the switch location ---


def test_hermite_root_is_exact_for_a_cubic():
    """The start of the switch location: the root of the cubic Hermite interpolant reproduces the root of a
    cubic exactly (end values and slopes determine it), here g(s) = (s0 − s)(1 + s²) on [0, H]."""
    from coexist.wrinkling import _hermite_root

    H = np.array([1.0, 2.0, 0.5, 1e-3])
    s0 = np.array([0.3, 1.5, 0.1, 7e-4])
    g = lambda s: (s0 - s) * (1 + s**2)  # noqa: E731
    dg = lambda s: -(1 + s**2) + (s0 - s) * 2 * s  # noqa: E731
    x = _hermite_root(H, g(0 * H), g(H), dg(0 * H), dg(H))
    assert x == pytest.approx(s0, rel=1e-12, abs=0)


def test_locate_converges_in_two_evaluations_from_the_hermite_start():
    """_locate on g(s) = cos(a + s) − cos(a + r) in steps of H = 0.4 (root s = r): the roots to 1e-14
    relative, every column done after at most two evaluations (Hermite start, error O(H⁴); one Newton step;
    a final one below NEWTON_FINAL taken without evaluating); from the secant alone it needs more."""
    from coexist.wrinkling import _locate

    a = np.array([0.2, 0.5, 0.9, 1.2])
    r = np.array([0.05, 0.2, 0.33, 0.38])
    H = np.full(4, 0.4)
    calls = []

    def fun(s, idx):
        calls.append(idx.size)
        return np.cos(a[idx] + s) - np.cos(a[idx] + r[idx]), -np.sin(a[idx] + s)

    g_lo, g_hi = np.cos(a) - np.cos(a + r), np.cos(a + H) - np.cos(a + r)
    x = _locate(fun, H.copy(), g_lo, g_hi, -np.sin(a), -np.sin(a + H))
    assert x == pytest.approx(r, rel=1e-14, abs=0)
    assert len(calls) <= 2
    calls.clear()
    x = _locate(fun, H.copy(), g_lo, g_hi)
    assert x == pytest.approx(r, rel=1e-14, abs=0)
    assert len(calls) >= 3


@pytest.mark.parametrize("n", [40, 300])  # the compiled attempt function (small batches) and numpy (large)
def test_wrinkled_states_restart_at_the_taut_shots_last_node(monkeypatch, n):
    """solve_states hands each wrinkled state to shoot_relaxed at the last node its taut shot vouches for
    (hoop tension still positive there, beyond the pole), and the states equal those shot from the pole
    (the same equations, another step sequence: to the integration's accuracy, 1e-9; derivatives 1e-6)."""
    import coexist.wrinkling as wr

    model = relaxed("gent")
    l0, phi = np.linspace(5.95, 6.9, n), 0.3
    seen = {}
    original = wr.shoot_relaxed

    def spy(model_, settings, l0_, phi_, derivatives=False, start=None):
        seen["start"] = start
        return original(model_, settings, l0_, phi_, derivatives, start=start)

    monkeypatch.setattr(wr, "shoot_relaxed", spy)
    st = solve_states(model, l0, phi, derivatives=True)
    start = seen["start"]
    assert np.all(st.wrinkled_fraction > 0) and np.all(st.ok)
    assert np.all(np.isfinite(start["R"])) and np.all(start["R"] > 100 * SolverSettings().series_radius)
    T2 = model.tensions(start["y"][0], start["y"][1], phi)[1]
    assert np.all(T2 > 0)
    # the same states shot from the pole
    shots = original(model, SolverSettings(), l0, np.full(n, phi), True)
    R = shots.out["R"]
    assert st.p_hat == pytest.approx(shots.out["p"] * R, rel=1e-9)
    assert st.v_hat == pytest.approx(shots.out["V"] / R**3, rel=1e-9)
    assert st.q_hat == pytest.approx(shots.out["Q"] / R**2, rel=1e-9)
    dp = shots.out["p"] * shots.out["dR_dl0"]
    assert st.derivatives.dp_dl0 == pytest.approx(dp, rel=1e-6, abs=1e-9 * np.abs(dp).max())
