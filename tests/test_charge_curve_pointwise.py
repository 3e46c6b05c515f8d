"""Every state and every turning point of a ``Φ̂–Q̂`` curve against :func:`voltage_at_pressure` solved point by
point (an independent root search at each pole stretch: safeguarded Newton from the regula falsi point of
``[0, s_pole]``, every shot with derivatives, no interpolated first guess, no chord steps), on the cases of
``benchmarks/bench_curve.py --charge-only`` (Gent Jlim 97 at ``p̂ = 1.5, 1.7, 1.2``, the last with its spiral
of eleven turning points), a neo-Hookean case and a prestretched one.

The tolerance is the curve's own ``rtol`` (the integration's relative tolerance, 1e-10 by default):

- the same pole stretches are accepted (the curve is the first run of states ``voltage_at_pressure`` finds,
  and its neighbours outside the run carry no voltage);
- the voltages agree as a pressure, ``|∂p̂/∂Φ̂| |ΔΦ̂| ≤ rtol p̂`` (a relative comparison of ``Φ̂`` itself would
  be meaningless where the curve starts at ``Φ̂ → 0``);
- ``V̂, Q̂, Ψ̂`` agree to ``2 rtol`` of their largest value on the curve once the reference is moved to the
  curve's voltage along its exact derivatives (``X + (∂X/∂Φ̂) ΔΦ̂``, with ``∂Ψ̂/∂Φ̂ = p̂ ∂V̂/∂Φ̂ − Q̂``); the
  apex height, the smallest tension and the largest field per volt ``Ê/Φ̂`` to ``10 rtol`` each (they have
  no derivative to move them by; ``ΔΦ̂/Φ̂`` is below 1e-8 here);
- each turning point is a root of the reference's ``dΦ̂/dλ0 = −(∂p̂/∂λ0)/(∂p̂/∂Φ̂)`` (voltage extrema) or
  ``dQ̂/dλ0 = ∂Q̂/∂λ0 + (∂Q̂/∂Φ̂) dΦ̂/dλ0`` (charge extrema): that derivative changes sign across
  ``λ0* ± 1e-4 λ0*`` and the Newton distance ``|t/t'|`` to its root is at most ``limit_point_xtol λ0*``;
  its voltage, charge and volume are the reference's at ``λ0*`` to ``rtol``; the turning points are the
  discrete extrema of the reference's own grid values, kind by kind.

No timings here (``benchmarks/bench_curve.py --charge-only`` measures them).
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import bounded

from coexist.curves import voltage_at_pressure, voltage_charge_curve
from coexist.model import build_model
from coexist.settings import SolverSettings

SETTINGS = SolverSettings()
CASES = ["gent-1.5", "gent-1.7", "gent-1.2", "neo-1.7", "prestretched-0.5"]


def _grid(model):
    return np.linspace(1.01 * model.prestretch, max(4.0, 1.5 * model.prestretch), 200)


@pytest.fixture(scope="module")
def solved():
    """Per case: the model, the curve, and ``voltage_at_pressure`` on the same 200 pole stretches."""
    models = {
        "gent": build_model("gent", 97.0),
        "neo": build_model("neo-hookean"),
        "prestretched": build_model("gent", 97.0, prestretch=2.0),
    }
    out = {}
    for case in CASES:
        name, p = case.rsplit("-", 1)
        model, grid = models[name], _grid(models[name])
        curve = bounded(voltage_charge_curve, model, float(p), grid, SETTINGS)
        out[case] = (model, curve, bounded(voltage_at_pressure, model, grid, float(p), SETTINGS))
    return out


def _along(d, kind):
    """``dΦ̂/dλ0`` (voltage extrema) or ``dQ̂/dλ0`` (charge extrema) along the curve, from the exact
    derivatives ``d`` (:class:`~coexist.shooting.StateDerivatives`)."""
    g = -d.dp_dl0 / d.dp_dphi
    return g if kind.startswith("voltage") else d.dq_dl0 + d.dq_dphi * g


@pytest.mark.parametrize("case", CASES)
def test_states_are_the_pointwise_roots(solved, case):
    model, c, ref = solved[case]
    grid, p, rtol = _grid(model), c.fixed, c.rtol
    at = np.searchsorted(grid, c.pole_stretch)
    assert np.array_equal(grid[at], c.pole_stretch) and np.all(np.diff(at) == 1)
    assert np.all(ref.ok[at])
    for i in (at[0] - 1, at[-1] + 1):  # the run is the whole run: its neighbours carry no voltage
        if 0 <= i < grid.size:
            assert not ref.ok[i]
    d = ref.derivatives.take(at)
    dphi = c.phi_hat - ref.phi_hat[at]
    assert np.all(np.abs(d.dp_dphi * dphi) <= rtol * p)
    assert np.all(np.abs(c.p_hat - p) <= rtol * p)
    moved = {
        "v_hat": ref.v_hat[at] + d.dv_dphi * dphi,
        "q_hat": ref.q_hat[at] + d.dq_dphi * dphi,
        "psi_hat": ref.psi_hat[at] + (p * d.dv_dphi - ref.q_hat[at]) * dphi,
    }
    for name, expected in moved.items():
        assert np.all(np.abs(getattr(c, name) - expected) <= 2 * rtol * np.max(np.abs(expected))), name
    for name in ("apex_height", "min_tension"):
        expected = getattr(ref, name)[at]
        assert np.all(np.abs(getattr(c, name) - expected) <= 10 * rtol * np.abs(expected)), name
    per_volt = ref.max_field[at] / ref.phi_hat[at]
    assert np.all(np.abs(c.max_field / c.phi_hat - per_volt) <= 10 * rtol * per_volt)


@pytest.mark.parametrize("case", CASES)
def test_turning_points_are_the_pointwise_roots(solved, case):
    model, c, ref = solved[case]
    grid, p, rtol = _grid(model), c.fixed, c.rtol
    assert c.limit_points
    # the same turning points, in order, as the changes of sign of the reference's slope along its grid, sampled
    # by the exact slope at every node and the secant of every interval between them (this finds those in
    # the first and last intervals and pairs within one interval; voltage and charge extrema separately: they
    # may share a grid interval)
    at = np.searchsorted(grid, c.pole_stretch)
    for attr, up, down in (("phi_hat", "voltage_max", "voltage_min"), ("q_hat", "charge_max", "charge_min")):
        v = getattr(ref, attr)[at]
        exact = _along(ref.derivatives.take(at), up)
        signs = np.sign(np.ravel(np.c_[exact[:-1], np.diff(v)]).tolist() + [exact[-1]])
        signs = signs[signs != 0]
        expected = [up if a > 0 else down for a, b in zip(signs[:-1], signs[1:]) if a != b]
        assert [lp.kind for lp in c.limit_points if lp.kind in (up, down)] == expected
    x = np.array(
        [[lp.pole_stretch * (1 - 1e-4), lp.pole_stretch, lp.pole_stretch * (1 + 1e-4)] for lp in c.limit_points]
    )
    around = bounded(voltage_at_pressure, model, x.ravel(), p, SETTINGS)
    assert np.all(around.ok)
    for j, lp in enumerate(c.limit_points):
        t = _along(around.derivatives.take(slice(3 * j, 3 * j + 3)), lp.kind)
        assert t[0] * t[2] < 0, lp.kind
        slope = (t[2] - t[0]) / (x[j, 2] - x[j, 0])
        assert abs(t[1] / slope) <= SETTINGS.limit_point_xtol * lp.pole_stretch, lp.kind
        k = 3 * j + 1
        assert abs(lp.phi_hat - around.phi_hat[k]) <= rtol * around.phi_hat[k]
        assert abs(lp.q_hat - around.q_hat[k]) <= rtol * abs(around.q_hat[k])
        assert abs(lp.v_hat - around.v_hat[k]) <= rtol * abs(around.v_hat[k])
        assert abs(lp.p_hat - p) <= rtol * p
