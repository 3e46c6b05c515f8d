"""A patterned zone's pole stretch below that of its flat (unpressurised) state has no equilibrium, and says so.

An electrode disc in a stiffer passive annulus, both prestretched: unpressurised, the three-layer annulus pulls
the one-layer disc open (its meridional force is continuous across the edge, so the disc stretches until the
annulus, contracting radially, balances it), and the flat zone's pole stretch is well above the prestretch
(1.4151 at Φ̂ = 0.1 for a Gent 97 zone at prestretch 1.2). Inflation only stretches the pole further. Below
that pole stretch the Newton iteration on the interface scale finds the clamp stretch reached before the rim at
every scale, down to where the zone is flat; it used to go on below the pole's series radius, integrating the
pole region backwards to a meaningless failure (``solver_budget`` or ``wrinkling``, after ~24000 steps). The
flat zone here is an independent 1-D radial problem (scipy), not the shooting."""

import re

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from coexist import shooting
from coexist.model import build_model
from coexist.patterned import ZonePattern, interface_stretch, solve_patterned_states
from coexist.shooting import OK, REASONS, STEP_LIMIT, WRINKLED, reason_tag

PHI = 0.1
FRACTION, LAYERS = 0.3, 3


@pytest.fixture(scope="module")
def zone():
    return build_model("gent", jlim=97.0, voltage=True, prestretch=1.2), ZonePattern.inner_circle(FRACTION, LAYERS)


def _flat_annulus(model, l0, stop_at_clamp):
    """The unpressurised zone with pole stretch ``l0``: the disc equibiaxial at ``l0`` (exact: ``(R T)' = T``,
    ``λ2' = 0``), the annulus from the force balance across the edge, integrated flat (θ = 0) outwards."""
    l1p = float(interface_stretch(model, np.array([l0]), np.array([l0]), PHI, 1, 0.0, LAYERS)[0][0])

    def rhs(R, y):
        d = model.rhs(R, y[0], y[1], 0.0, 0.0, 0.0)
        return [float(d[0]), float(d[1])]

    def clamp(R, y):
        return y[1] - model.prestretch

    clamp.terminal = True
    end, events = (10.0, clamp) if stop_at_clamp else (1.0, None)
    return solve_ivp(rhs, (FRACTION, end), [l1p, l0], rtol=1e-11, atol=1e-13, method="DOP853", events=events)


def _flat_pole_stretch(model):
    return brentq(lambda l0: _flat_annulus(model, l0, False).y[1, -1] - model.prestretch, 1.21, 2.0, xtol=1e-12)


def test_flat_zone_pole_stretch_is_where_the_curve_starts(zone):
    """The flat zone's pole stretch (independent) lies between the last state without equilibrium and the first
    valid one; the first valid one's pressure is small (p̂² ∝ λ0 − λflat near the flat end)."""
    model, pattern = zone
    flat = _flat_pole_stretch(model)
    assert abs(flat - 1.4150676750) < 1e-8  # measured (solve_ivp at rtol 1e-11, brentq to 1e-12): the docs' 1.41507
    st = solve_patterned_states(model, pattern, [flat - 0.003, flat + 0.005, flat + 0.02], PHI)
    assert st.status[0] != OK and st.status[1] == OK and st.status[2] == OK
    # p̂² linear in λ0 near the flat end: extrapolated to zero at the flat pole stretch
    p2 = st.p_hat[1:] ** 2
    at_zero = (flat + 0.005) - p2[0] * 0.015 / (p2[1] - p2[0])
    assert abs(at_zero - flat) < 2e-4


@pytest.mark.parametrize("l0", [1.212, 1.3, 1.40814])
def test_below_the_flat_zone_is_no_equilibrium_not_a_budget_or_wrinkling(zone, l0):
    """Below the flat zone's pole stretch: status BELOW_FLAT, tag ``no_equilibrium`` (not ``solver_budget``,
    not ``wrinkling``), in a few hundred steps, and where the detail says the clamp stretch is reached is where
    the independent flat zone reaches it (the zone is flat at that scale to ~1e-5)."""
    model, pattern = zone
    st = solve_patterned_states(model, pattern, [l0], PHI)
    assert st.status[0] not in (STEP_LIMIT, WRINKLED), st.failure_detail[0]
    assert reason_tag(st.status[0]) == "no_equilibrium"
    BELOW_FLAT = shooting.BELOW_FLAT
    assert st.status[0] == BELOW_FLAT
    assert st.failure_detail[0].startswith(REASONS[BELOW_FLAT][1])
    assert st.steps[0] < 2000  # it was ~2700 (wrinkling) to ~24000 (solver_budget)
    reach = float(re.search(r"reached at ([0-9.]+) of the rim radius", st.failure_detail[0]).group(1))
    independent = float(_flat_annulus(model, l0, True).t_events[0][0])
    assert abs(reach - independent) < 2e-5


def test_curve_starts_because_below_flat(zone):
    """The curve's reason for starting late names the flat zone, not a radius search or a step budget."""
    from coexist.patterned import patterned_pressure_volume_curve

    model, pattern = zone
    c = patterned_pressure_volume_curve(model, pattern, PHI)
    assert c.states.pole_stretch[0] > _flat_pole_stretch(model)
    assert c.starts_because.startswith("no_equilibrium: ")
    assert "no pressure holds a pole stretch this small: unpressurised" in c.starts_because
