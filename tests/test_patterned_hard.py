"""Patterned zones near the voltage at which the pole wrinkles (a hard case found on the ``inner-circle`` Φ̂–Q̂
curve).

The pole region of a pattern is integrated at the stack's trial pressure, which the passive annulus keeps
large while the pole region's own scale (∝ its pole tension) falls to zero near the pole-wrinkling voltage:
a series started at the uniform zone's radius then missed the boundary layer at the pole, and the states
depended on the tolerance (``p̂`` off by 4e-3 at rtol 1e-10, the Φ̂–Q̂ curve jumping to another branch and the
Maxwell relation failing by 1e-1). The series now starts at the radius scaled to the pole region
(:func:`coexist.patterned.pole_series_radius`).
"""

import numpy as np
import pytest

from coexist.curves import voltage_charge_curve
from coexist.patterned import PatternedModel
from coexist.scene import load_scene
from coexist.settings import SolverSettings
from coexist.shooting import StateDerivatives, solve_states


@pytest.fixture(scope="module")
def model():
    sc = load_scene("inner-circle")
    return PatternedModel.of(sc.model(), sc.zone_pattern())


def test_states_near_pole_wrinkling_do_not_depend_on_the_tolerance(model):
    """At 99.3–99.9 % of the pole-wrinkling voltage the states at rtol 1e-8 and 1e-13 agree to 1e-9 (they
    differed by up to 0.3 before)."""
    l0 = np.array([3.4724, 3.5226, 3.5477])
    phi = np.array([0.323188, 0.321887, 0.320645])
    loose = solve_states(model, l0, phi, SolverSettings(rtol=1e-8)).require_ok()
    tight = solve_states(model, l0, phi, SolverSettings(rtol=1e-13)).require_ok()
    for name in ("p_hat", "v_hat", "q_hat"):
        a, b = getattr(loose, name), getattr(tight, name)
        assert np.max(np.abs(a - b) / np.abs(b)) < 1e-9, name


def test_charge_curve_is_one_branch_with_exact_derivatives(model):
    """The Φ̂–Q̂ curve at p̂ = 1.5 ends where the pole wrinkles, without jumping to another branch, and the
    Maxwell relation ∂p̂/∂Φ̂|V̂ = −∂Q̂/∂V̂|Φ̂ holds at every state to 1e-7 (measured 1.2e-8)."""
    c = voltage_charge_curve(model, 1.5)
    s = c.states
    assert s.pole_stretch[-1] < 3.55 and s.pole_stretch.size > 60
    assert np.max(np.abs(np.diff(s.v_hat))) < 0.05  # neighbouring states 0.025 apart in λ0
    d = StateDerivatives.of(solve_states(model, s.pole_stretch, s.phi_hat, derivatives=True))
    lhs = d.dp_dphi - d.dp_dl0 * d.dv_dphi / d.dv_dl0
    rhs = -d.dq_dl0 / d.dv_dl0
    assert np.max(np.abs(lhs - rhs) / np.maximum(np.abs(rhs), 1e-3)) < 1e-7


@pytest.mark.parametrize("electrode_pole", [True, False])
def test_charge_curve_of_a_two_layer_stack_is_the_one_layer_curve_scaled(electrode_pole):
    """A zone of two layers everywhere, fully electroded, is the one-layer zone at ``Φ̂/2`` carrying ``p̂/2``: its
    Φ̂–Q̂ curve at ``p̂`` has, at every pole stretch, twice the one-layer curve's voltage at ``p̂/2``, the same
    volume and charge (1e-9). The voltage search must bracket the pole-wrinkling voltage of the stack, ``2²``
    times the one-layer one (it missed every root above the one-layer bound before). A ring with a passive pole
    region (whose pole never wrinkles by the voltage) finds the states the curve's own re-shot pressure confirms."""
    from coexist.patterned import ZonePattern

    sc = load_scene("inner-circle")
    uniform = sc.model()
    grid = np.linspace(1.05, 2.2, 24)
    if electrode_pole:
        stack = PatternedModel.of(uniform, ZonePattern([(0.5, 2, True), (1.0, 2, True)]))
        two = voltage_charge_curve(stack, 1.5, grid).states
        one = voltage_charge_curve(uniform, 0.75, grid).states
        both = np.intersect1d(two.pole_stretch, one.pole_stretch)
        assert both.size >= 5 and np.array_equal(two.pole_stretch, one.pole_stretch)
        a, b = np.isin(two.pole_stretch, both), np.isin(one.pole_stretch, both)
        assert np.allclose(two.phi_hat[a], 2 * one.phi_hat[b], rtol=1e-9, atol=0)
        assert np.allclose(two.v_hat[a], one.v_hat[b], rtol=1e-9, atol=0)
        assert np.allclose(two.q_hat[a], one.q_hat[b], rtol=1e-9, atol=0)
    else:
        ring = PatternedModel.of(uniform, ZonePattern.ring(0.3, 0.7, passive_layers=2))
        c = voltage_charge_curve(ring, 2.0, grid).states
        assert c.pole_stretch.size >= 10
        again = solve_states(ring, c.pole_stretch, c.phi_hat)
        assert np.allclose(again.p_hat, 2.0, rtol=1e-9, atol=0)
