"""Jumps whose zones lie on different runs of valid states of the zone curve (:meth:`coexist.ramp.Ramp._curves_of`).

Near pressure control (a 1e6 ml chamber) a Gent zone with late locking bulges so far that, at the voltage of the next
jump, it lies past a stretch of states that fail (tension-field wrinkles that pull in) or past the jump grid's end.
The jump's gradient flow had only the curve from the flat state, which ends before that zone; the ramp exited 1
("lies past the zone curve ... the jump cannot be followed on it"). Now each group moves on the run that holds it, and
a group that reaches the end of its run ends the jump there (the model cannot follow it through failed states).
"""

import json
import re

import numpy as np
import pytest
from click.testing import CliRunner
from conftest import central_difference_jacobian

from coexist.cli.main import cli
from coexist.ramp import Ramp, gradient_flow
from coexist.scene import builtin_scene_text, parse_scene
from coexist.shooting import solve_states
from coexist.simulation import Simulation


def _text(jlim, volume_ml=1000000):
    text = re.sub(r"^volume_ml = .*$", f"volume_ml = {volume_ml}", builtin_scene_text("tricircle"), flags=re.M)
    return re.sub(r"^jlim = .*$", f"jlim = {jlim}", text, flags=re.M)


def _transitions(report):
    return [(t.kind, t.direction, t.from_label, t.to_label) for t in report.result.transitions]


@pytest.fixture(scope="module")
def gent200():
    sim = Simulation.from_scene(parse_scene(_text(200)))
    return sim, sim.ramp()


def test_gent_200_on_a_huge_chamber_ends_where_the_second_zone_would_cross_the_pull_in(gent200):
    """Gent 200, 1e6 ml: at 2.781 kV the unbulged pair of 1 of 3 bulged splits while the bulged zone sits at pole
    stretch 9.33, beyond states that fail from 8.78 to 9.02. The inflating zone of the pair has no state at the gas's
    pressure before that gap, so it would have to pass through it: the ramp ends there ("no_stable_state") instead of
    exiting 1.

    Checked on exact shots, independently of the splines and the flow: at the jump's voltage the states between
    pole stretch 8.80 and 9.00 fail, valid ones hold the bulged zone on either side of 9.33, and no state from the
    pair's pole stretch to the gap carries the gas's pressure (all lie below it). Asserted: the transitions, their
    voltages to 1e-6 kV of the values measured (their own error is ~3e-9 kV), and the reason named."""
    sim, report = gent200
    assert _transitions(report)[:2] == [
        ("spinodal", "up", "homogeneous", "1 of 3 bulged"),
        ("no_stable_state", "up", "1 of 3 bulged", "none"),
    ]
    split, end = report.result.transitions[:2]
    kv = sim.scene.voltage_scale / 1e3
    assert split.phi_hat * kv == pytest.approx(0.818945072, abs=1e-6)
    assert end.phi_hat * kv == pytest.approx(2.781214366, abs=1e-6)
    assert end.event == "split"
    assert "leaves the model's range on the way from 1 of 3 bulged (electromechanical_instability" in end.reason
    lost = end.state_before
    lam = np.sort(np.asarray(lost.pole_stretch))
    assert lam[-1] == pytest.approx(9.33, abs=0.01) and lam[0] < 2.2
    phi = end.phi_hat * (1 + 1e-5)
    gap = solve_states(sim.model, np.linspace(8.80, 9.00, 9), phi, sim.settings)
    assert not gap.ok.any()
    around = solve_states(sim.model, np.array([9.10, lam[-1], 9.40]), phi, sim.settings)
    assert around.ok.all()
    below = solve_states(sim.model, np.linspace(lam[0] + 0.05, 8.75, 200), phi, sim.settings)
    assert below.ok.all() and np.max(below.p_hat) < lost.p_hat


def test_each_group_flows_on_the_run_that_holds_it(gent200):
    """The lost state of the Gent 200 case, pushed as the jump pushes it: the bulged group gets a curve of its own
    (a run that starts past the failed states, within one of the jump grid's spacings of 9.02) and stays on it; the
    inflating zone leaves the first curve at its end (8.78), which is what ends the jump."""
    sim, report = gent200
    end = report.result.transitions[1]
    ramp = Ramp(sim.emap, sim.lam_max)
    phi = end.phi_hat * (1 + 1e-5)
    seg = next(s for s in report.result.segments if s.label == "1 of 3 bulged")
    counts, u, dv, _ = ramp._push(end.source, seg)
    curves, why = ramp._curves_of(phi, u)
    assert curves is not None, why
    first = ramp._curve(phi)
    assert curves[0] is first and curves[1] is first and curves[2] is not first
    run = curves[2]
    assert 9.0 < run.to_stretch(run.grid[0]) < 9.06 and run.grid[0] < u[2] < run.grid[-1]
    assert first.to_stretch(first.grid[-1]) == pytest.approx(8.78, abs=0.01)
    start = u + 1e-3 * dv / np.maximum([c.dv(x) for c, x in zip(curves, u)], 1e-12)
    counts_end, u_end, status, _ = gradient_flow(curves, sim.emap.gas, counts, start, settings=sim.settings)
    assert status == "range_end"
    assert run.grid[0] <= u_end[2] <= run.grid[-1]  # the bulged zone stayed on its run
    assert np.max(u_end[:2]) == pytest.approx(first.grid[-1], abs=1e-6)  # the inflating zone at the first curve's end


def test_a_zone_past_the_jump_grid_gets_its_run(tmp_path):
    """Gent 300, 1e6 ml: the bulged zone of 1 of 3 bulged reaches pole stretch 11.84, past the jump grid's end (11.69,
    0.95 of the locking stretch) and past states whose poles wrinkle from 4.57: its run is shot on the grid continued
    past it. The split at 3.849 kV then ends the ramp as the inflating zone reaches a volume fold with no stable state
    beyond (it had exited 1)."""
    path = tmp_path / "gent300.toml"
    path.write_text(_text(300))
    r = CliRunner().invoke(cli, ["ramp", str(path), "--json"])
    assert r.exit_code == 0, r.output
    data = json.loads(r.stdout)
    kinds = [(t["kind"], t["from"], t["to"]) for t in data["transitions"]]
    assert kinds[:2] == [("spinodal", "homogeneous", "1 of 3 bulged"), ("no_stable_state", "1 of 3 bulged", "none")]
    assert data["transitions"][1]["voltage_kV"] == pytest.approx(3.849319029, abs=1e-6)
    assert "volume fold" in data["transitions"][1]["reason"]


def test_gent_150_follows_the_second_zone_then_ends():
    """Gent 150, 1e6 ml: the second zone bulges at 2.154 kV, and 2 of 3 bulged ends at its fold at 3.219 kV, a zone
    leaving the model's range on the way (the ramp had exited 1 at that fold: a bulged zone lay past the first
    curve). The
    second bulging comes later the smaller the chamber is, as the gas's stiffness holds the pair back: 3e6 ml ~1.57 kV
    at Gent 200 against 1.06 kV at 1e7 ml (pressure control: all three at once)."""
    report = Simulation.from_scene(parse_scene(_text(150))).ramp()
    assert _transitions(report)[:3] == [
        ("spinodal", "up", "homogeneous", "1 of 3 bulged"),
        ("spinodal", "up", "1 of 3 bulged", "2 of 3 bulged"),
        ("no_stable_state", "up", "2 of 3 bulged", "none"),
    ]
    second, end = report.result.transitions[1:3]
    assert report.voltage_kV(second.phi_hat) == pytest.approx(2.154470636, abs=1e-6)
    assert report.voltage_kV(end.phi_hat) == pytest.approx(3.219372128, abs=1e-6)
    assert "leaves the model's range on the way from 2 of 3 bulged" in end.reason


def test_the_flow_jacobian_on_two_runs(gent200):
    """:class:`coexist.ramp._FlowEquations` with one bundle per group (the first curve for a group of 2, the bulged
    zone's run for 1): its exact Jacobian against central differences of its right-hand side, at the lost state of
    the Gent 200 case and pushed off it. Measured 1e-9 of the largest entry; asserted 1e-6."""
    from coexist.numerics.splines import CubicBundle
    from coexist.ramp import _FlowEquations

    sim, report = gent200
    end = report.result.transitions[1]
    ramp = Ramp(sim.emap, sim.lam_max)
    phi = end.phi_hat * (1 + 1e-5)
    lam = np.sort(np.asarray(end.state_before.pole_stretch))
    u = np.sqrt(np.array([lam[0], lam[-1]]) - sim.model.prestretch)
    curves, _ = ramp._curves_of(phi, u)
    assert curves[0] is not curves[1]
    bundles = [CubicBundle((c.p, c.v)) for c in curves]
    lo, hi = [c.grid[0] for c in curves], [c.grid[-1] for c in curves]
    eqs = _FlowEquations(bundles, sim.emap.gas, (2, 1), lo, hi, [1e-12, 1e-12], 1e-8)
    for x in (u, u + np.array([0.05, -0.01])):
        J = eqs.jacobian(0.0, x)
        fd = central_difference_jacobian(lambda y: eqs.rhs(0.0, y), x)
        assert np.max(np.abs(J - fd)) <= 1e-6 * np.max(np.abs(J)), (x, J, fd)
        # each group evaluated on its own curve
        p, *_ = eqs.terms(x)
        assert p[0] == pytest.approx(float(curves[0].p(x[0])), rel=1e-14)
        assert p[1] == pytest.approx(float(curves[1].p(x[1])), rel=1e-14)


def test_a_zone_in_a_gap_or_at_a_run_start_is_named(gent200):
    """The messages of the two ends of what the flow can follow: a zone on a failed state (Gent 200 at the jump's
    voltage, pole stretch 8.9, inside the states that pull in from 8.78 to 9.02) lies on no run, and a group at the
    start of a later run ends the jump naming the gap below it."""
    from coexist.ramp import _end_reached

    sim, report = gent200
    end = report.result.transitions[1]
    ramp = Ramp(sim.emap, sim.lam_max)
    phi = end.phi_hat * (1 + 1e-5)
    pre = sim.model.prestretch
    curves, why = ramp._curves_of(phi, np.sqrt(np.array([2.0, 8.9]) - pre))
    assert curves is None
    assert "a zone (pole stretch 8.9) lies past the zone curve" in why and "on no run of valid states beyond it" in why
    first = ramp._curve(phi)
    run = ramp._run_through(phi, float(np.sqrt(9.33 - pre)))
    text = _end_reached([run], [float(run.grid[0])], first)
    assert text.startswith("the states below pole stretch 9.0") and "the start of the run it was on" in text
    assert _end_reached([first, run], [float(first.grid[-1]), 3.0], first).startswith("electromechanical_instability")


def test_a_narrow_gap_the_coarse_grid_missed(tmp_path):
    """Three inner-circle zones (electrode 0.3 of the radius) of Gent 300 on a 1e6 ml chamber: at 4.262 kV the bulged
    zone sits at pole stretch 11.876, and the states between the coarse grid's points fail only from 11.765 to 11.770
    (checked on exact shots): the fine run through the zone starts again past that gap (review, helper-86: the ramp had
    exited 1, "on no run of valid states"). It ends as its neighbours with 0.5 and 0.7 do, the inflating zone at a
    volume fold."""
    text = re.sub(r"^volume_ml = .*$", "volume_ml = 1000000", builtin_scene_text("tricircle"), flags=re.M)
    text = re.sub(r"^jlim = .*$", "jlim = 300", text, flags=re.M)
    text = text.replace("[zones]", '[electrodes]\npattern = "inner-circle"\ninner_fraction = 0.3\n\n[zones]')
    sim = Simulation.from_scene(parse_scene(text))
    report = sim.ramp()
    assert _transitions(report)[:2] == [
        ("spinodal", "up", "homogeneous", "1 of 3 bulged"),
        ("no_stable_state", "up", "1 of 3 bulged", "none"),
    ]
    end = report.result.transitions[1]
    assert report.voltage_kV(end.phi_hat) == pytest.approx(4.261968666, abs=1e-6)
    assert "volume fold" in end.reason
    phi = end.phi_hat * (1 + 1e-5)
    gap = solve_states(sim.model, np.array([11.7655, 11.7675, 11.7695]), phi, sim.settings)
    assert not gap.ok.any()
    sides = solve_states(sim.model, np.array([11.70, 11.876, 12.0]), phi, sim.settings)
    assert sides.ok.all()


def test_a_landing_on_a_later_run_gets_its_zone_index_there(gent200):
    """:meth:`Ramp._polish` on the lost state of the Gent 200 case, just before its split (still stable): the bulged
    zone lies on the later run, and its zone index is read on that run's curve. The indices agree with the ones the
    continuation gave the exact state (its folds counted on exact slopes), and the state is the same one. (The first
    curve, clipped at its end, would give the bulged zone index 0 here too: what fails without the runs is the
    dispatch, asserted first.)"""
    from coexist.equilibria import Configuration

    sim, report = gent200
    end = report.result.transitions[1]
    lost = end.state_before
    ramp = Ramp(sim.emap, sim.lam_max)
    phi = end.phi_hat * (1 - 1e-6)
    lam = np.sort(np.asarray(lost.pole_stretch))
    groups = [lam[0], lam[-1]]  # the unbulged pair, the bulged zone
    u = np.sqrt(np.array(groups) - sim.model.prestretch)
    curves, _ = ramp._curves_of(phi, u)
    assert curves[1] is not ramp._curve(phi)  # the bulged zone is on the later run
    eq = ramp._polish(Configuration((2, 1)), u, phi)
    assert eq is not None and eq.stable
    assert tuple(eq.zone_index) == tuple(lost.zone_index)
    assert np.sort(eq.pole_stretch) == pytest.approx(np.sort(lost.pole_stretch), rel=1e-4)
