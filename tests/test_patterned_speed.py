"""The fast path of the patterned shooting and the patterned voltage–charge curves.

:func:`coexist.patterned.solve_patterned_states` integrates small batches (up to a few hundred states) region by
region with the shooting's compiled attempt functions and large ones step by step in numpy: both are the same
DOP853 steps, so a state is the same whichever batch it is solved in (to the integration tolerance, here 1e-9
relative at rtol 1e-10; measured ~1e-13). ``coexist curves`` computes a patterned zone's Φ̂–Q̂ curves when
``--p-hat`` asks for them: every state of such a curve, shot again directly at its ``(λ0, Φ̂)``, carries the
curve's pressure (1e-9 relative) and its charge, the electrode's only (the Maxwell relation of the electrode
charge holds, 1e-8, where the curve is well conditioned); a one-region full pattern gives the uniform zone's
curve (1e-9). The ramp cost of a patterned scene is the measured factor times a uniform scene's.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from click.testing import CliRunner

from coexist.curves import voltage_charge_curve
from coexist.model import build_model
from coexist.patterned import PatternedModel, ZonePattern, solve_patterned_states
from coexist.settings import SolverSettings
from coexist.shooting import OK

PATTERN = ZonePattern.inner_circle(0.5, passive_layers=2)


@pytest.fixture(scope="module")
def gent():
    return build_model("gent", jlim=97.0, voltage=True)


def test_a_state_is_the_same_in_a_small_and_a_large_batch(gent):
    """300 states (two chunks of the compiled attempt functions, or numpy steps where nothing is compiled) and
    three of them alone: the same states."""
    l0 = np.linspace(1.5, 3.5, 300)
    big = solve_patterned_states(gent, PATTERN, l0, 0.1)
    pick = np.array([0, 137, 299])
    small = solve_patterned_states(gent, PATTERN, l0[pick], 0.1)
    assert np.all(big.status[pick] == OK) and np.all(small.status == OK)
    for name in ("p_hat", "v_hat", "q_hat", "psi_hat", "apex_height", "min_tension"):
        a, b = getattr(big, name)[pick], getattr(small, name)
        assert np.max(np.abs(a - b) / np.abs(b)) < 1e-9, (name, a, b)
    # and one state alone is the state of a batch of three (its columns are integrated independently)
    one = solve_patterned_states(gent, PATTERN, l0[pick[1:2]], 0.1)
    assert one.p_hat[0] == pytest.approx(small.p_hat[1], rel=1e-13, abs=0)


def test_the_cli_computes_patterned_voltage_charge_curves(gent):
    """``coexist curves --scene inner-circle --p-hat 1.5``: every state re-shot directly holds p̂ = 1.5 and the
    curve's charge; the charge is the electrode's (Maxwell: ``p̂_Φ V̂_λ − p̂_λ V̂_Φ = −Q̂_λ`` with that charge)."""
    from coexist.cli.main import cli

    args = ["curves", "--scene", "inner-circle", "--phi-hat", "0.1", "--p-hat", "1.5", "--points", "24", "--json"]
    result = CliRunner().invoke(cli, args)
    assert result.exit_code == 0, result.output
    data = json.loads(result.stdout)
    assert [c["family"] for c in data["curves"]] == ["pressure_volume", "voltage_charge"]
    vq = data["curves"][1]
    l0, phi, q = (np.array(vq[k]) for k in ("pole_stretch", "phi_hat", "q_hat"))
    assert l0.size >= 10 and np.all(phi > 0)
    again = solve_patterned_states(gent, PATTERN, l0, phi, derivatives=True)
    assert np.all(again.status == OK), again.failure_detail
    assert np.max(np.abs(again.p_hat - 1.5)) / 1.5 < 1e-9, again.p_hat
    np.testing.assert_allclose(again.q_hat, q, rtol=1e-9, atol=0)
    # (up to λ0 = 2.5: past it the volume hardly changes along the curve and the relation's terms cancel,
    # measured 1e-8 at 2.7 and 1e-1 at 3.5, where the derivatives themselves lose digits)
    d = again.derivatives.take(l0 <= 2.5)
    lhs = d.dp_dphi * d.dv_dl0 - d.dp_dl0 * d.dv_dphi
    assert d.dq_dl0.size >= 6
    assert np.max(np.abs(lhs + d.dq_dl0) / np.abs(d.dq_dl0)) < 1e-8
    # the electrode covers a quarter of the area: far less charge than the full electrode at these voltages
    full = solve_patterned_states(gent, ZonePattern.full(), l0, phi)
    assert np.all(q < 0.6 * full.q_hat)


def test_a_one_region_full_pattern_gives_the_uniform_voltage_charge_curve(gent):
    grid = np.linspace(1.05, 3.5, 30)
    settings = SolverSettings()
    plain = voltage_charge_curve(gent, 1.5, grid, settings)
    zone = voltage_charge_curve(PatternedModel.of(gent, ZonePattern.full()), 1.5, grid, settings)
    for name in ("pole_stretch", "phi_hat", "v_hat", "q_hat"):
        np.testing.assert_allclose(getattr(zone.states, name), getattr(plain.states, name), rtol=1e-9, atol=0)
    assert [lp.kind for lp in zone.limit_points] == [lp.kind for lp in plain.limit_points]
    for a, b in zip(zone.limit_points, plain.limit_points):
        assert a.phi_hat == pytest.approx(b.phi_hat, rel=1e-9, abs=0)


def test_the_ramp_cost_of_a_patterned_scene_is_the_measured_factor_times_the_uniform_one():
    from coexist.cost import PATTERNED_TIME_FACTOR, SECONDS_PER_NUMBER, ramp_cost
    from coexist.scene import builtin_scene_text, parse_scene

    base = builtin_scene_text("tricircle").replace('wrinkling = "tension-field"', 'wrinkling = "refuse"')
    pat = base.replace("[zones]", '[electrodes]\npattern = "inner-circle"\ninner_fraction = 0.8\n\n[zones]')
    uniform, patterned = ramp_cost(parse_scene(base)), ramp_cost(parse_scene(pat))
    assert patterned.numbers == uniform.numbers and patterned.memory_bytes == uniform.memory_bytes
    printing = SECONDS_PER_NUMBER * uniform.numbers
    assert patterned.seconds - printing == pytest.approx(
        PATTERNED_TIME_FACTOR * (uniform.seconds - printing), rel=1e-12
    )
    # benchmarks/bench_patterned.py measured this ramp at 2.4–2.9 s (the uniform one 0.46–0.51 s): the estimate is
    # not below what was measured, nor more than twice it
    assert 2.9 <= patterned.seconds < 5.8, patterned.seconds


def test_the_fast_curve_holds_its_states_solved_one_by_one_tightly(gent):
    """The curve's Newton passes on the interface scale start from the converged neighbours, keep the pole region
    from pass to pass and reuse the last slope where the residual was already small: every state of the headline
    curve (inner circle 0.5, two-layer annulus, Gent 97, Φ̂ = 0.1) and its pressure maximum are the same states
    solved alone from the cap estimate at rtol 1e-12, to 1e-9 relative (p̂, V̂; Q̂ and Ψ̂ too)."""
    from coexist.patterned import patterned_pressure_volume_curve

    curve = patterned_pressure_volume_curve(gent, PATTERN, 0.1)
    st = curve.states
    assert st.pole_stretch.size >= 190 and np.all(st.status == OK)
    tight = SolverSettings(rtol=1e-12)
    names = ("p_hat", "v_hat", "q_hat", "psi_hat")
    worst = dict.fromkeys(names, 0.0)
    for i, l0 in enumerate(st.pole_stretch):
        alone = solve_patterned_states(gent, PATTERN, [l0], 0.1, tight)
        assert alone.status[0] == OK, (l0, alone.failure_detail)
        for name in names:
            a, b = getattr(st, name)[i], getattr(alone, name)[0]
            worst[name] = max(worst[name], abs(a - b) / abs(b))
    assert max(worst.values()) < 1e-9, worst
    (top,) = [lp for lp in curve.limit_points if lp.kind == "pressure_max"]
    alone = solve_patterned_states(gent, PATTERN, [top.pole_stretch], 0.1, tight)
    assert top.p_hat == pytest.approx(alone.p_hat[0], rel=1e-9, abs=0)
    assert top.v_hat == pytest.approx(alone.v_hat[0], rel=1e-9, abs=0)
    # the maximum itself: no state on the curve lies above it (measured 2.2665279776)
    assert top.p_hat >= np.max(st.p_hat) * (1 - 1e-12)
    assert top.p_hat == pytest.approx(2.2665279776, rel=1e-9, abs=0)


def test_the_scale_interpolation_is_exact_for_polynomials_and_estimates_its_error():
    """:func:`coexist.patterned._interpolate` (the curve's starts): the 6-point Lagrange polynomial reproduces a
    quintic to rounding, one value row or several at once; its error estimate (the difference from the 5-point
    polynomial) is the size of the last term: ~0 for a quartic; for a smooth function never below half the true
    error and at most 5 times its largest (measured 0.66 to 26 times pointwise, median 3.7; 4.4 at the largest)."""
    from coexist.patterned import _interpolate

    nodes = np.linspace(0.0, 2.0, 15) ** 1.3
    x = np.linspace(-0.1, 2.2, 97)  # ends outside the nodes: clamped to them
    inside = np.clip(x, nodes[0], nodes[-1])
    quintic = np.poly1d([0.3, -1.0, 0.5, 2.0, -0.7, 1.1])
    quartic = np.poly1d([-1.0, 0.5, 2.0, -0.7, 1.1])
    both, err = _interpolate(nodes, np.vstack([quintic(nodes), quartic(nodes)]), x)
    np.testing.assert_allclose(both[0], quintic(inside), rtol=0, atol=1e-11)
    np.testing.assert_allclose(both[1], quartic(inside), rtol=0, atol=1e-11)
    assert np.max(err) > 1e-6  # the quintic's last term is not zero
    assert np.max(_interpolate(nodes, quartic(nodes), x)[1]) < 1e-11
    value, err = _interpolate(nodes, np.sin(3 * nodes), x)
    true = np.abs(value - np.sin(3 * inside))
    between = (x > nodes[0]) & (x < nodes[-1]) & (true > 1e-9)
    assert np.all(err[between] > 0.5 * true[between])
    assert np.max(err) < 5 * np.max(true)


def test_the_headline_curve_takes_five_passes_and_a_pass_for_each_limit_point_evaluation(gent):
    """The headline curve's grid is one Newton iteration: the coarse states (evenly spaced in
    ``(λ0/λpre − 1)^0.4``) three passes, then every other state joins from their polynomial and converges in two
    (the first without variational equations where the interpolated slope serves); the pressure maximum's
    evaluations one pass each plus the derivative pass (twice the states) where its exact slope is asked: the
    node slopes at the curve's ends and bends (6 states), two roots of the slope (its state is the derivative
    call's: not evaluated again), and its error's two states at rtol/100 (two passes to the tighter tolerance).
    Measured: passes of 26, 26, 26, 196, 176 states, then 6 + 12, 1 + 2, 1 + 2, 2 + 2 + 4."""
    import coexist.patterned as pat

    sizes = []
    original = pat._pass

    def counted(*args, **kwargs):
        sizes.append(args[3].size)
        return original(*args, **kwargs)

    pat._pass = counted
    try:
        curve = pat.patterned_pressure_volume_curve(gent, PATTERN, 0.1)
    finally:
        pat._pass = original
    assert np.all(curve.states.status == OK)
    assert len(sizes) <= 14, sizes
    assert sum(sizes) <= 26 * 3 + 200 * 2 + 40, sizes
    assert sizes[:3] == [26, 26, 26] and sizes[5:] == [6, 12, 1, 2, 1, 2, 2, 2, 4], sizes


def test_a_rejected_step_in_two_halves_is_the_adaptive_integration(gent):
    """:func:`coexist.patterned._in_halves` (a landing step rejected in one, taken in two halves by the compiled step
    function): where both halves are accepted it is ``dop853.integrate`` from ``h0 = span/2`` (its second step the
    rest) to rounding, 1e-13 (measured 4e-16), in 2 steps; where a half is rejected (a span of 0.3 from
    ``R̂ = 0.3``) the adaptive integration takes over, the same to 1e-13 and in its steps."""
    from coexist.numerics import dop853
    from coexist.patterned import _in_halves, _layout, _pole_start, _single_step, _stepper, _trial, _trial_pressures
    from coexist.shooting import _integrators

    settings = SolverSettings()
    l0 = np.array([1.5, 2.0, 3.0])
    lay = _layout(PATTERN, np.full(3, 0.1))
    tp = _trial_pressures(gent, lay, l0)
    p_t, rtol = _trial(gent, settings, lay, l0, tp)
    y0, atol, _, _, _, R0 = _pole_start(gent, settings, lay, l0, p_t, tp)
    fns = _integrators(gent)
    mid = dop853.integrate(fns.radius, R0.copy(), y0, np.full(3, 0.3), rtol, atol, 1000)
    t0 = np.full(3, 0.3)
    for span, halves in ((0.08, True), (0.3, False)):
        _, err = _single_step(_stepper(fns, "radius", 3), t0, mid.y, np.full(3, span), rtol[None, :], atol)
        assert np.any(err > 1.0), err  # rejected in one step
        y, steps, reached = _in_halves(fns, "radius", t0, mid.y, t0 + span, rtol, atol, 100)
        ref = dop853.integrate(fns.radius, t0, mid.y, t0 + span, rtol, atol, 100, h0=np.full(3, span / 2))
        assert np.all(reached) and np.all(ref.status == dop853.REACHED_END)
        np.testing.assert_allclose(y, ref.y, rtol=1e-13, atol=1e-300)
        np.testing.assert_array_equal(steps, ref.steps)
        assert np.all(steps == 2) == halves, steps


def test_warm_interface_jumps_do_not_change_which_states_exist():
    """A pass starts each interface's stretch ``λ1⁺`` from the last pass's or a neighbour's; near the outer side's
    electromechanical instability such a start can reach a far, stiffening branch of ``T̂1(λ1)`` that
    :func:`~coexist.patterned.interface_stretch` refuses, and the curve then returned states that do not exist when
    solved alone (review of 2026-12-01: 121 states where 98 did). An electrode ring ``0.3 < R/A < 0.7`` in a
    three-layer passive membrane, Gent 97, ``Φ̂ = 0.15``: the curve's states are those solved one by one (every
    eighth and the last four: the same statuses, ``p̂`` to 1e-9). Those 98 were themselves short: at ``λ0 = 2.5``
    the electrode side of the inner edge carries ``T̂1 = 8.09`` at ``λ2 = 2.45``, reached on its rising branch at
    ``λ1 ≈ 5.7`` (no maximum of ``T̂1`` below locking there), but the bracket doubled to ``λ1 ≈ 11`` met the locked
    region and the state was refused as unstable; every state up to ``λ0 = 4`` exists."""
    from coexist.effects import Gent
    from coexist.model import MembraneModel
    from coexist.patterned import patterned_pressure_volume_curve
    from coexist.shooting import solve_states

    model = MembraneModel(elasticity=Gent(97.0))
    settings = SolverSettings()
    pattern = ZonePattern.ring(0.3, 0.7, passive_layers=3)
    l0 = np.linspace(1.01, 4, 200)
    curve = patterned_pressure_volume_curve(model, pattern, 0.15, l0, settings)
    assert curve.states.ok.all() and curve.states.pole_stretch.size == 200
    zone = PatternedModel.of(model, pattern)
    picks = np.r_[np.arange(0, 200, 8), np.arange(196, 200)]
    alone = solve_states(zone, l0[picks], 0.15, settings)
    assert alone.ok.all()
    np.testing.assert_allclose(curve.states.p_hat[picks], alone.p_hat, rtol=1e-9)
    one = [solve_states(zone, [l0[i]], 0.15, settings) for i in (97, 98, 120)]
    for i, a in zip((97, 98, 120), one):
        assert a.ok[0] and a.p_hat[0] == pytest.approx(curve.states.p_hat[i], rel=1e-9)


def test_states_beyond_the_end_of_a_curve_are_not_solved():
    """A ring electrode (neo-Hookean, ring 0.3–0.7, Φ̂ = 0.3) whose curve ends where it wrinkles (pole stretch
    2.15191): the states beyond ran out of integration steps at every placement of the interfaces tried (λ0 ≥ 2.5:
    up to 26 527 steps each) and the curve took 2.4 s. Once a state of the Newton iteration has ended without a valid
    state beyond a valid one, the states beyond it are no longer solved: 13 397 integration steps in all passes
    (1 401 230 before; 446 trajectories, 2 304 before), the same curve (its states solved alone, its end, its
    pressure maximum)."""
    import coexist.patterned as pat

    model, ring = build_model("neo-hookean"), ZonePattern.ring(0.3, 0.7)
    steps = []
    original = pat._pass

    def counted(*args, **kwargs):
        out = original(*args, **kwargs)
        steps.append(int(np.sum(out[4])))  # the integration steps of every trajectory of the pass
        return out

    pat._pass = counted
    try:
        curve = pat.patterned_pressure_volume_curve(model, ring, 0.3)
    finally:
        pat._pass = original
    assert sum(steps) < 50_000, sum(steps)
    st = curve.states
    assert st.pole_stretch[-1] == pytest.approx(2.1519095477, abs=1e-9)
    assert curve.stopped_because.startswith("wrinkling: beyond pole stretch 2.15191 a tension turns negative")
    (top,) = curve.limit_points
    assert top.kind == "pressure_max" and top.pole_stretch == pytest.approx(1.6793113639, abs=2e-9)
    alone = solve_patterned_states(model, ring, st.pole_stretch, 0.3)
    assert np.all(alone.status == OK)
    np.testing.assert_allclose(st.p_hat, alone.p_hat, rtol=1e-9, atol=0)
    np.testing.assert_allclose(st.v_hat, alone.v_hat, rtol=1e-9, atol=0)
    # the next pole stretch is where it wrinkles, solved alone as well
    beyond = solve_patterned_states(model, ring, [2.1669346734], 0.3)
    assert beyond.status[0] != OK


def test_states_left_unsolved_are_solved_when_the_run_reaches_them(gent, monkeypatch):
    """The states beyond one that ended the first run of valid states in the Newton iteration are left unsolved;
    should the run reach them after all (that state found valid by the retry from the cap, or the states before it
    failing their relaxation), they are solved. Forced here by ending the run early (every state beyond the 80th
    of the headline curve's grid left unsolved): the same curve as without it, its run, reasons and limit points."""
    import coexist.patterned as pat

    expected = pat.patterned_pressure_volume_curve(gent, PATTERN, 0.1)
    cut = {"done": False}

    def early(waiting, open_, final, wrinkled_valid):
        beyond = np.zeros(waiting.size, dtype=bool)
        if not cut["done"] and waiting.any():
            cut["done"] = True
            beyond[80:] = True
        return beyond

    monkeypatch.setattr(pat, "_beyond_run_end", early)
    curve = pat.patterned_pressure_volume_curve(gent, PATTERN, 0.1)
    assert cut["done"]
    np.testing.assert_array_equal(curve.states.pole_stretch, expected.states.pole_stretch)
    np.testing.assert_allclose(curve.states.p_hat, expected.states.p_hat, rtol=1e-9, atol=0)
    assert (curve.starts_because, curve.stopped_because) == (expected.starts_because, expected.stopped_because)
    assert [lp.kind for lp in curve.limit_points] == [lp.kind for lp in expected.limit_points]
    for a, b in zip(curve.limit_points, expected.limit_points):
        assert a.pole_stretch == pytest.approx(b.pole_stretch, abs=1e-9)
