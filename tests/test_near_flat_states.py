"""States of a patterned zone just above its flat (unpressurised) pole stretch are found, and those below say so.

Gent 97 inner circle (f = 0.3, a three-layer passive annulus, prestretch 1.2). Near the flat end the residual of
the interface-scale Newton iteration is ``G(σ) ≈ a − b e^{2σ}`` with ``a ∝ λ0 − λflat``: its slope at the root is
``≈ −2a``, above ``SLOPE_CEILING``. The steps used to take the uniform zone's slope −1 there (a step of ``−G``),
and crawled (~1e-2 per pass where ~1 was needed): every state within ~3e-3 of the flat pole stretch ended after 30
passes as ``NO_CLAMP`` ("max_radius_factor"), though it exists (p̂ 0.0035 at +1e-6, 0.11 at +1e-3). Below the flat
pole stretch the same crawl ran out of passes before the trial at the smallest scale could say ``BELOW_FLAT``.

Checked independently: p̂² is linear in ``λ0 − λflat`` (the flat pole stretch from a 1-D scipy solve of the flat
zone, tests/test_pattern_below_flat.py), and a scipy ``solve_ivp`` shooting of the zone (the pole series start,
DOP853 at rtol 1e-12, the interface jump by ``brentq`` on the stack force) finds the same pressure by ``brentq``
on ``λ2(1) = λpre``."""

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from coexist.curves import pressure_volume_curve
from coexist.model import build_model
from coexist.patterned import PatternedModel, ZonePattern, interface_stretch, solve_patterned_states
from coexist.shooting import BELOW_FLAT, OK, REASONS

FRACTION, LAYERS = 0.3, 3
#: the flat pole stretch at Φ̂ = 0.1 (tests/test_pattern_below_flat.py, to 1e-8) and at 0.15 (the same 1-D solve)
FLAT = {0.1: 1.4150676750, 0.15: 1.4198860896}
#: p̂²/(λ0 − λflat) at Φ̂ = 0.1, measured from +1e-5 to +1e-3 (12.36286–12.36292; 12.3597 at +3e-3)
P2_SLOPE = 12.3629


@pytest.fixture(scope="module")
def zone():
    return build_model("gent", jlim=97.0, voltage=True, prestretch=1.2), ZonePattern.inner_circle(FRACTION, LAYERS)


def _flat_pole_stretch(model, phi):
    """The flat zone's pole stretch (independent: the disc equibiaxial, the annulus integrated flat)."""

    def rim(l0):
        l1p = float(interface_stretch(model, np.array([l0]), np.array([l0]), phi, 1, 0.0, LAYERS)[0][0])

        def rhs(R, y):
            d = model.rhs(R, y[0], y[1], 0.0, 0.0, 0.0)
            return [float(d[0]), float(d[1])]

        sol = solve_ivp(rhs, (FRACTION, 1.0), [l1p, l0], rtol=1e-11, atol=1e-13, method="DOP853")
        return sol.y[1, -1] - model.prestretch

    return brentq(rim, 1.21, 2.0, xtol=1e-12)


def _t1(model, l1, l2, phi):
    return float(np.asarray(model.tensions(l1, l2, phi)[0]))


def _rim_stretch(model, l0, p, phi, R0=1e-3):
    """λ2 at the rim R̂ = 1 of the zone shot by scipy at pressure p̂ (from the pole series at R̂0)."""
    y0 = [float(np.asarray(v)) for v in model.series_start(l0, p, phi, R0)[:3]]

    def rhs(ph, pp):
        def f(R, y):
            d = model.rhs(R, y[0], y[1], y[2], pp, ph)
            return [float(d[0]), float(d[1]), float(d[2])]

        return f

    kw = dict(rtol=1e-12, atol=1e-14, method="DOP853")
    a = solve_ivp(rhs(phi, p), (R0, FRACTION), y0, **kw)
    l1m, l2, th = a.y[:, -1]
    target = _t1(model, l1m, l2, phi) / LAYERS  # the stack force n T̂1 continuous (one layer in, LAYERS out)
    l1p = brentq(lambda x: _t1(model, x, l2, 0.0) - target, 0.25 / l2, 2.0 * l1m, xtol=1e-15)
    b = solve_ivp(rhs(0.0, p / LAYERS), (FRACTION, 1.0), [l1p, l2, th], **kw)
    return b.y[1, -1]


def _independent_pressure(model, l0, phi, guess):
    return brentq(
        lambda p: _rim_stretch(model, l0, p, phi) - model.prestretch, 0.7 * guess, 1.3 * guess, xtol=1e-15, rtol=1e-13
    )


def test_flat_pole_stretches(zone):
    model, _ = zone
    for phi, flat in FLAT.items():
        assert abs(_flat_pole_stretch(model, phi) - flat) < 1e-8


def test_states_just_above_the_flat_pole_stretch_exist(zone):
    """From +1e-6 to +1e-3 above the flat pole stretch: valid states (they were NO_CLAMP, "max_radius_factor"),
    p̂² linear in λ0 − λflat (to 1e-4 relative from +1e-5 on, 1e-3 at +1e-6 where the interface placement's
    tolerance over the slope 2a ≈ 2e-5 allows ~1e-6 in p̂), extrapolating to 0 at the flat pole stretch."""
    model, pattern = zone
    eps = np.array([1e-6, 3e-6, 1e-5, 1e-4, 3e-4, 1e-3])
    st = solve_patterned_states(model, pattern, FLAT[0.1] + eps, 0.1)
    assert np.all(st.status == OK), [d for d in st.failure_detail if d]
    ratio = st.p_hat**2 / eps
    assert abs(ratio[0] / P2_SLOPE - 1) < 1e-3
    assert np.all(np.abs(ratio[1:] / P2_SLOPE - 1) < 1e-4), ratio
    # p̂ ≈ 0.0035 at +1e-6, 0.11 at +1e-3 (the brief's "≈ 0.004–0.11")
    assert 0.003 < st.p_hat[0] < 0.004 and 0.10 < st.p_hat[-1] < 0.12


@pytest.mark.parametrize("eps", [1e-6, 1e-5, 1e-3])
def test_near_flat_state_matches_independent_shooting(zone, eps):
    """p̂ of the state against scipy's shooting of the zone: 2e-6 relative at +1e-6 (the residual |G| ≤ 1e-10
    over the slope ≈ 2e-5), 2e-7 from +1e-5 on; and the independent shooting at the state's own p̂ reaches the
    clamp stretch at the rim to 1e-10."""
    model, pattern = zone
    l0 = FLAT[0.1] + eps
    st = solve_patterned_states(model, pattern, [l0], 0.1)
    assert st.status[0] == OK, st.failure_detail[0]
    p = float(st.p_hat[0])
    assert abs(_rim_stretch(model, l0, p, 0.1) - model.prestretch) < 1e-10
    p_ref = _independent_pressure(model, l0, 0.1, p)
    assert abs(p / p_ref - 1) < (2e-6 if eps < 1e-5 else 2e-7)


@pytest.mark.parametrize("phi", [0.1125, 0.115, 0.12])
def test_below_flat_says_below_flat(zone, phi):
    """λ0 = 1.400172, 0.016 below the flat pole stretch at Φ̂ ≈ 0.115: BELOW_FLAT (it was NO_CLAMP after 30 passes
    whose last was the trial at the smallest scale)."""
    model, pattern = zone
    st = solve_patterned_states(model, pattern, [1.400172], phi)
    assert st.status[0] == BELOW_FLAT, st.failure_detail[0]
    assert st.failure_detail[0].startswith(REASONS[BELOW_FLAT][1])
    assert "max_radius_factor" not in st.failure_detail[0]


def test_curve_starts_at_its_first_grid_point_above_flat(zone):
    """Φ̂ = 0.15 on the default grid: the curve starts at 1.422151 (0.0023 above the flat pole stretch; it started
    one grid point late, at 1.436161), that state's p̂ matching the independent shooting to 1e-8, and its start
    is explained by the flat zone."""
    model, pattern = zone
    c = pressure_volume_curve(PatternedModel.of(model, pattern), 0.15)
    first = float(c.states.pole_stretch[0])
    assert abs(first - (1.212 + 15 * 2.788 / 199)) < 1e-9 and first > FLAT[0.15]
    p = float(c.states.p_hat[0])
    assert abs(p / _independent_pressure(model, first, 0.15, p) - 1) < 1e-8
    assert "no pressure holds a pole stretch this small" in c.starts_because


def test_fine_grid_from_the_flat_end(zone):
    """A curve on a grid from 1e-6 above the flat pole stretch (two points below it) starts at its first point
    above (it started at +2.5e-3, 22 points late), p̂² linear in λ0 − λflat up to +1e-3."""
    model, pattern = zone
    flat = FLAT[0.1]
    grid = np.concatenate([flat + np.array([-1e-3, -1e-6]), flat + np.geomspace(1e-6, 3e-2, 30)])
    c = pressure_volume_curve(PatternedModel.of(model, pattern), 0.1, pole_stretch=grid)
    assert c.states.pole_stretch[0] == grid[2]
    assert c.starts_because.startswith("no_equilibrium: ")
    assert "no pressure holds a pole stretch this small" in c.starts_because
    near = c.states.pole_stretch - flat <= 1e-3  # p̂² linear there to 1e-4 (it bends by 4e-3 at +3e-2)
    assert near.sum() == 20
    assert np.all(np.abs(c.states.p_hat[near] ** 2 / (c.states.pole_stretch[near] - flat) / P2_SLOPE - 1) < 1e-4)
