"""Equal-free-energy voltages between segments of one configuration (helper-36).

The tricircle with inner-circle electrodes of 0.9 of the zone radius and two passive layers listed the
homogeneous -> 1 of 3 bulged crossing (3.739988002 kV) twice and four "1 of 3 bulged -> 1 of 3 bulged"
crossings whose measured errors were 0.06 to 18 kV.

What the states are: the 1-of-3-bulged branch has a tiny swallowtail near 3.72909 kV. Along the branch the
voltage rises from the lower stable piece's fold at 3.7233810 kV (bulged pole stretch 3.01) to a fold at
F2 = 3.7290950862 kV (pole stretch ≈ 3.79), falls to a fold at F1 = 3.7290925936 kV (≈ 3.84) and rises
again to the pull-in at 4.3393555 kV (the ramp's up-going pull-in). So there are two stable pieces,
L = [3.7233810, F2] and U = [F1, 4.3393555], that overlap on 2.5e-6 kV. The continuation stepped across
both folds at once (the fold function, the tangent's voltage component, has one sign at both ends of that
step): L was traced through the unstable piece onto U and on to the pull-in, so it repeated U's states
over [F1, 4.339]. Where two segments hold the same states, ``ΔĜ`` is rounding (±2e-12) whose sign changes
were "located" (kV-sized errors), and the homogeneous state crossed both at the same voltage.

Fixed: a step across which the Hermite slope of ``wΦ̂`` dips is shortened, and short ones are examined at
points inside (both folds are located, L ends at F2); a crossing whose two states are one state gives
none; a crossing found twice is listed once. The one genuine bulged<->bulged crossing, inside (F1, F2),
stays, with a small error.
"""

import numpy as np
import pytest
from conftest import bounded

from coexist.continuation import Point, StableSegment
from coexist.ramp import equal_free_energy
from coexist.scene import builtin_scene_text, parse_scene
from coexist.simulation import Simulation


def inner_circle_scene(fraction: float):
    """The tricircle with inner-circle electrodes and two passive layers, ramped 0 -> 4.4 kV by 0.2 kV."""
    text = builtin_scene_text("tricircle").replace("stop_kV = 5\nstep_kV = 0.02", "stop_kV = 4.4\nstep_kV = 0.2")
    assert "stop_kV = 4.4" in text
    text += f'\n[electrodes]\npattern = "inner-circle"\ninner_fraction = {fraction}\n[layers]\npassive = 2\n'
    return parse_scene(text)


@pytest.fixture(scope="module")
def ramp09():
    sim = Simulation.from_scene(inner_circle_scene(0.9))
    return sim, bounded(sim.ramp, seconds=60)


def bulged(report):
    """The 1-of-3-bulged segments of a ramp, by their low end."""
    segs = [s for s in report.result.segments if s.configuration.counts == (2, 1)]
    return sorted(segs, key=lambda s: s.phi_range[0])


def test_the_bulged_branch_has_two_stable_pieces_that_end_at_their_folds(ramp09):
    """Two 1-of-3-bulged segments: L from its fold at 3.7233810 kV to its fold F2, U from its fold F1 to the
    pull-in at 4.3393555 kV; F1 < F2 by 2.4926e-6 kV (measured). Before the fix L ended at the
    pull-in too (its high end a range_end). Tolerances: 1e-8 kV on the fold voltages (their measured
    errors are 4e-9), 20 % on the overlap width."""
    _, report = ramp09
    kv = report.voltage_kV
    low, up = bulged(report)
    assert low.low.kind == "fold" and low.high.kind == "fold", (low.low.kind, low.high.kind)
    assert up.low.kind == "fold" and up.high.kind == "range_end"
    f1, f2 = kv(up.phi_range[0]), kv(low.phi_range[1])
    assert kv(low.phi_range[0]) == pytest.approx(3.7233810112, abs=1e-8)
    assert f1 == pytest.approx(3.7290925936, abs=1e-8)
    assert f2 == pytest.approx(3.7290950862, abs=1e-8)
    assert 0.8 * 2.49e-6 < f2 - f1 < 1.2 * 2.49e-6
    # the two pieces hold different states where both exist: the bulged zone's pole stretch differs by ≈ 0.06
    mid = 0.5 * (up.phi_range[0] + low.phi_range[1])
    el, eu = low.states([mid])[0], up.states([mid])[0]
    assert abs(max(el.pole_stretch) - max(eu.pole_stretch)) > 0.02


def test_equal_free_energy_lists_each_crossing_once_with_a_small_error(ramp09):
    """Two crossings (before: six, one of them twice, four with errors of 0.06-18 kV): homogeneous -> 1 of 3
    bulged at 3.739988002 kV and L <-> U at 3.7290938384 kV (measured; error 7.7e-9 kV), each error measured
    at rtol/100 and below 5e-8 kV."""
    _, report = ramp09
    kv = report.voltage_kV
    eqs = report.result.equal_free_energy
    got = sorted((round(kv(t.phi_hat), 8), t.from_label, t.to_label) for t in eqs)
    assert [(g[1], g[2]) for g in got] == [
        ("1 of 3 bulged", "1 of 3 bulged"),
        ("homogeneous", "1 of 3 bulged"),
    ], got
    for t in eqs:
        assert t.measured and 0 < kv(t.phi_hat_error) < 5e-8, (kv(t.phi_hat), kv(t.phi_hat_error))
    homog = [t for t in eqs if t.from_label == "homogeneous"][0]
    assert kv(homog.phi_hat) == pytest.approx(3.739988002, abs=1e-8)


def test_the_bulged_crossing_is_a_sign_change_inside_the_overlap(ramp09):
    """The L <-> U crossing lies strictly inside (F1, F2), and the exact ``ΔĜ = ĜL − ĜU`` changes sign across
    it: at a tenth of the overlap from either end (exact states, not the crossing's own) ``|ΔĜ|`` is at least
    1e-9 (measured −2.36e-8 and +2.38e-8; the rounding of ``Ĝ ≈ −1.25e4`` is ≈ 2e-12), of opposite signs;
    the two states at the crossing differ (bulged pole stretch 3.766 on L, 3.863 on U)."""
    _, report = ramp09
    low, up = bulged(report)
    t = [t for t in report.result.equal_free_energy if t.from_label == t.to_label][0]
    assert {id(s) for s in t.segments} == {id(low), id(up)}
    f1, f2 = up.phi_range[0], low.phi_range[1]
    assert f1 < t.phi_hat < f2
    x = np.array([f1 + 0.1 * (f2 - f1), f2 - 0.1 * (f2 - f1)])
    dg = np.array([a.free_energy - b.free_energy for a, b in zip(low.states(x), up.states(x))])
    assert np.all(np.abs(dg) > 1e-9) and dg[0] * dg[1] < 0, dg
    assert abs(max(t.state_before.pole_stretch) - max(t.state_after.pole_stretch)) > 0.02


def test_segments_repeating_one_stretch_of_states_give_no_crossing_of_their_own(ramp09):
    """U traced a second time from another of its points (a different set of points over the same states):
    U and its copy give no crossing (``ΔĜ`` between them is rounding), and the homogeneous state's crossing
    with both is listed once. Before the fix: the homogeneous crossing twice (and, for the old L, kV-sized
    noise roots)."""
    sim, report = ramp09
    homog = [s for s in report.result.segments if s.configuration.counts == (3,)][0]
    _, up = bulged(report)
    tr = up.tracer
    seed = tr.seed(up.points[len(up.points) // 2].z, up.points[0].index)
    copy = StableSegment(tr.trace(seed, stable_only=True), tr, up.branches)
    assert copy.phi_range == pytest.approx(up.phi_range, abs=1e-9)
    crossings = bounded(equal_free_energy, [homog, up, copy])
    assert len(crossings) == 1, [(c.from_label, c.to_label, c.phi_hat) for c in crossings]
    assert report.voltage_kV(crossings[0].phi_hat) == pytest.approx(3.739988002, abs=1e-8)


def _point(u: float, phi_w: float, slope: float) -> Point:
    t = np.array([1.0, slope]) / np.hypot(1.0, slope)
    return Point(np.array([u, phi_w]), t, None, None, None, (0,), True, 0.0)


def test_a_step_whose_voltage_slope_dips_inside_it_is_suspect():
    """``wΦ̂ = u³ − 0.6 u`` on ``u ∈ [−1, 1]`` (slopes 2.4 at both ends, two folds at ``u = ±0.447``): the
    Hermite slope dips inside, at the middle (``τ`` within 0.1 of 0.5). ``wΦ̂ = u² + 2u`` on ``[0, 1]`` (slope
    rising from 2 to 4) does not dip; a step whose ends' slopes differ in sign is left to the fold event."""
    from coexist.continuation import _voltage_dip

    tau = _voltage_dip(_point(-1.0, -0.4, 2.4), _point(1.0, 0.4, 2.4), 1)
    assert tau is not None and abs(tau - 0.5) < 0.1, tau
    assert _voltage_dip(_point(0.0, 0.0, 2.0), _point(1.0, 3.0, 4.0), 1) is None
    assert _voltage_dip(_point(0.0, 0.0, 1.0), _point(1.0, 0.0, -1.0), 1) is None
