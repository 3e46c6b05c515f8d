"""Warm starts of the patterned shooting in a continuation (:class:`coexist.patterned.ScaleStarts`).

A continuation keeps the converged states of its patterned zone and starts each new state's Newton iteration on
the interface scale from the nearest kept one (the scale extrapolated to first order with ``dσ/dλ0``, ``dσ/dΦ̂``
from the implicit function theorem, its exact slope and interface stretches as the hint). A start is never a
result: the states are the cold ones to the solver's tolerance, the ramp's transitions agree within their measured
errors, and a wrong start costs passes, not accuracy. Measured on ``coexist ramp inner-circle``: the continuation's
column-passes 5987 → 3627 (the whole ramp's 9006 → 6646).
"""

from __future__ import annotations

import copy
import pickle

import numpy as np
import pytest

import coexist.equilibria as equilibria
import coexist.patterned as patterned
from coexist.model import build_model
from coexist.patterned import PatternedModel, ScaleStarts, ZonePattern
from coexist.settings import SolverSettings
from coexist.shooting import OK, solve_states

PATTERN = ZonePattern.inner_circle(0.5, passive_layers=2)


@pytest.fixture(scope="module")
def zone():
    return PatternedModel.of(build_model("gent", jlim=97.0, voltage=True), PATTERN)


def _count_columns(monkeypatch) -> dict:
    """Count the columns of every Newton pass of the patterned shooting (derivative passes included)."""
    count = {"cols": 0}
    orig = patterned._pass

    def counting(*args, **kwargs):
        count["cols"] += len(args[3])
        return orig(*args, **kwargs)

    monkeypatch.setattr(patterned, "_pass", counting)
    return count


@pytest.fixture
def columns(monkeypatch):
    return _count_columns(monkeypatch)


def _fields(st):
    return {k: getattr(st, k) for k in ("p_hat", "v_hat", "q_hat", "psi_hat", "clamp_radius")}


@pytest.mark.parametrize("step, bound", [(1e-4, 0.75), (3e-3, 0.9)])
def test_warm_states_are_the_cold_ones_in_fewer_passes(zone, columns, step, bound):
    """States a corrector's step (1e-4) or a predictor's (3e-3) away from kept ones: the cold states to 1e-8
    relative (rtol 1e-10, times the sensitivity of p̂ to the interfaces' placement; measured 1e-11), in fewer
    columns (measured, with the derivative pass's two per state: 68 and 85 of 102 cold, 2 and 3 Newton passes
    per state instead of 4)."""
    settings = SolverSettings()
    l0 = np.linspace(1.6, 3.2, 17)
    phi = np.full(l0.size, 0.1)
    starts = ScaleStarts()
    solve_states(zone, l0, phi, settings, derivatives=True, starts=starts)
    assert len(starts) == l0.size
    near_l0, near_phi = l0 + step, phi + step / 2
    columns["cols"] = 0
    cold = solve_states(zone, near_l0, near_phi, settings, derivatives=True)
    n_cold = columns["cols"]
    columns["cols"] = 0
    warm = solve_states(zone, near_l0, near_phi, settings, derivatives=True, starts=starts)
    n_warm = columns["cols"]
    assert np.all(cold.status == OK) and np.all(warm.status == OK)
    assert n_warm <= bound * n_cold, (n_warm, n_cold)
    for name, a in _fields(cold).items():
        b = getattr(warm, name)
        assert np.max(np.abs(a - b) / np.abs(a)) < 1e-8, name
    for name in ("dp_dl0", "dv_dl0", "dp_dphi", "dv_dphi"):
        a, b = getattr(cold.derivatives, name), getattr(warm.derivatives, name)
        assert np.max(np.abs(a - b) / np.maximum(np.abs(a), 1e-3)) < 1e-6, name
    assert len(starts) == 2 * l0.size  # the new states are kept too


def test_the_first_order_start_is_second_order_accurate(zone):
    """The kept ``dσ/dλ0`` and ``dσ/dΦ̂`` are the converged scale's (the trial pressure's own change included):
    a step of 1e-3 in each leaves an error of order 1e-6 (measured up to 2.6e-6; zeroth order: ~5e-4)."""
    settings = SolverSettings()
    starts = ScaleStarts()
    solve_states(zone, [2.0], [0.1], settings, derivatives=True, starts=starts)
    for dl, dp in ((1e-3, 0.0), (0.0, 1e-3), (1e-3, -1e-3)):
        x, y = np.array([2.0 + dl]), np.array([0.1 + dp])
        guess, hint = starts.start(zone.uniform, PATTERN, x, y)
        exact = np.log(solve_states(zone, x, y, settings).clamp_radius)
        assert abs(guess[0] - exact[0]) < 1e-5, (dl, dp, guess, exact)
        assert np.isfinite(hint["slope"][0]) and set(hint["jump"]) == {1}


def test_a_wrong_start_is_only_a_start(zone):
    """Kept scales made wrong by 0.3 (and slopes by a factor 2): the states are still the cold ones."""
    settings = SolverSettings()
    l0 = np.linspace(1.8, 3.0, 7)
    starts = ScaleStarts()
    solve_states(zone, l0, 0.1, settings, derivatives=True, starts=starts)
    kept = starts._zone(zone.uniform, PATTERN, "taut")
    kept["sigma"] = kept["sigma"] + 0.3
    kept["slope"] = kept["slope"] * 2.0
    cold = solve_states(zone, l0 + 1e-3, 0.1, settings)
    warm = solve_states(zone, l0 + 1e-3, 0.1, settings, starts=starts)
    assert np.all(warm.status == OK)
    for name, a in _fields(cold).items():
        assert np.max(np.abs(a - getattr(warm, name)) / np.abs(a)) < 1e-8, name


def test_the_store_is_bounded_far_states_start_cold_and_copies_start_empty(zone):
    settings = SolverSettings()
    starts = ScaleStarts(kept=5)
    solve_states(zone, np.linspace(1.8, 3.0, 9), 0.1, settings, starts=starts)
    assert len(starts) == 5
    guess, _ = starts.start(zone.uniform, PATTERN, np.array([2.95, 1.8]), np.array([0.1, 0.1]))
    assert np.isfinite(guess[0]) and np.isnan(guess[1])  # 1.8 was dropped, the nearest kept is 2.4
    assert starts.start(zone.uniform, ZonePattern.inner_circle(0.4), np.array([2.0]), np.array([0.1])) is None
    assert len(pickle.loads(pickle.dumps(starts))) == 0 and len(copy.deepcopy(starts)) == 0


def _ramp(monkeypatch, warm: bool):
    from coexist.scene import load_scene
    from coexist.simulation import simulate_ramp

    if not warm:
        monkeypatch.setattr(equilibria, "scale_starts", lambda model: None)
        import coexist.continuation as continuation

        monkeypatch.setattr(continuation, "scale_starts", lambda model: None)
    count = {"cols": 0}  # the passes inside the continuation's shootings only
    orig = equilibria.shoot_groups
    columns_seen = _count_columns(monkeypatch)

    def counted(*args, **kwargs):
        before = columns_seen["cols"]
        out = orig(*args, **kwargs)
        count["cols"] += columns_seen["cols"] - before
        return out

    monkeypatch.setattr(equilibria, "shoot_groups", counted)
    report = simulate_ramp(load_scene("inner-circle"))
    monkeypatch.undo()
    return report.result, count["cols"]


def test_the_ramp_of_the_inner_circle_warm_and_cold(monkeypatch):
    """``coexist ramp inner-circle``: the continuation's patterned column-passes fall from 5987 (cold) to 3627
    (bound 4500), and the ramp is the same: the same steps and transitions, the transition voltages within their
    measured errors (measured 0.03 of it), every step's pressure within twice the corrector's residual tolerance
    ``residual_tol (1 + p̂)`` (each of the two is converged to it; measured 1.1), its pole stretches and volumes
    to 1e-8 relative (measured 2e-10)."""
    cold, n_cold = _ramp(monkeypatch, warm=False)
    warm, n_warm = _ramp(monkeypatch, warm=True)
    assert n_cold > 5000 and n_warm <= 4500, (n_cold, n_warm)
    assert len(cold.transitions) == len(warm.transitions) and len(cold.steps) == len(warm.steps)
    for a, b in zip(cold.transitions, warm.transitions):
        assert (a.kind, a.from_label, a.to_label, a.direction) == (b.kind, b.from_label, b.to_label, b.direction)
        assert abs(a.phi_hat - b.phi_hat) <= max(a.phi_hat_error, b.phi_hat_error), (a.phi_hat, b.phi_hat)
    settings = SolverSettings()
    worst = {"p": 0.0, "x": 0.0}
    for a, b in zip(cold.steps, warm.steps):
        assert (a.state is None) == (b.state is None) and a.direction == b.direction
        if a.state is None:
            continue
        assert a.state.configuration == b.state.configuration
        # the pressure to the corrector's residual tolerance (converged: residual below residual_tol (1 + p̂))
        tol = settings.residual_tol * (1 + a.state.p_hat)
        worst["p"] = max(worst["p"], abs(a.state.p_hat - b.state.p_hat) / tol)
        for x, y in ((a.state.pole_stretch, b.state.pole_stretch), (a.state.v_hat, b.state.v_hat)):
            worst["x"] = max(worst["x"], float(np.max(np.abs(np.subtract(x, y)) / np.abs(x))))
    assert worst["p"] <= 2.0 and worst["x"] <= 1e-8, worst
