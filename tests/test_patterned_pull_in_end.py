"""The pull-in end of a patterned zone: the tricircle scene with inner-circle electrodes (0.84 of the zone radius)
in a two-layer passive annulus, tension-field wrinkling. The bulged zone's wrinkled band pulls in at
4.3414126764 kV, where its stiffness along the natural width, ``K = dT̂1ʷ/dλ1`` (relative to ``T̂11``), falls
linearly to zero.

The continuation step that met the end failed about 2e-5 (arclength) before it: its Newton iterates, from a
predictor that overshoots the curving branch, crossed the end. The pull-in extrapolation then converged on the
real end, but its states lay beyond that failed step and were refused; the fallback bisection on validity (whose
loose probes failed the same way) closed on the failed step and put the end there, at 4.34138 kV, on a state whose
stiffness was still 9.5e-4. Its re-location at rtol/100 found the real end and the error became 6e-5 kV.
"""

import numpy as np
import pytest

import coexist.continuation as continuation
from coexist import Simulation, SolverSettings
from coexist.scene import builtin_scene_text, parse_scene

#: the end at rtol 1e-10 (4.3414126764 kV) and 1e-12 (4.341412676348 kV, the full 0 -> 5 kV scene) agree to 1e-10
#: kV (measured); located as the root of the stiffness extrapolated from the valid side, and checked below by
#: states on either side of it
END_KV = 4.3414126764


def _scene():
    text = builtin_scene_text("tricircle").replace(
        "start_kV = 0\nstop_kV = 5\nstep_kV = 0.02", "values_kV = [0, 4.33, 4.35]"
    )
    text += '\n[electrodes]\npattern = "inner-circle"\ninner_fraction = 0.84\n[layers]\npassive = 2\n'
    return parse_scene(text)


def _end(rtol):
    sim = Simulation.from_scene(_scene(), SolverSettings(rtol=rtol))
    report = sim.ramp()
    (t,) = [t for t in report.result.transitions if t.kind == "no_stable_state"]
    return t, report, sim


@pytest.fixture(scope="module")
def located():
    return _end(1e-10)


def test_pull_in_end_of_an_inner_circle_zone_has_its_real_error(located):
    t, report, _ = located
    kv, err = report.voltage_kV(t.phi_hat), report.voltage_kV(t.phi_hat_error)
    assert t.source.note.startswith("electromechanical_instability: a wrinkled")
    assert t.measured
    # old code: 4.34138358 kV ± 5.8e-5 (the failed step); the error now is the extrapolation's last change,
    # the re-location's change (1.7e-10 kV) and the floor 10 rtol Φ̂: 1.5e-8 kV measured
    assert err < 3e-8
    assert abs(kv - END_KV) < 1e-8
    # the state kept as the end's is the extrapolation's last, 1.2e-5 (arclength) before it (old: K = 9.5e-4)
    assert min(t.source.eq.wrinkled_stiffness) < 6e-4


def test_pull_in_end_agrees_with_the_high_accuracy_run(located):
    t, report, _ = located
    t_high, report_high, _ = _end(1e-12)
    kv, err = report.voltage_kV(t.phi_hat), report.voltage_kV(t.phi_hat_error)
    assert abs(report_high.voltage_kV(t_high.phi_hat) - kv) <= err


def test_states_either_side_of_the_end(located):
    # tight states along the end's tangent: valid with a vanishing stiffness just before it, failing past it (old
    # code: the state 1e-5 past its end was valid, K = 4.6e-4)
    t, _, sim = located
    ev = t.source
    tight = sim._tight_map().tracer(t.source_counts)  # rtol 1e-12, as the re-location's
    M = tight.M
    base = continuation.Point(ev.z.copy(), ev.tangent, ev.eq, np.zeros(M), np.zeros(M), (0,) * M, True)
    before, after = tight._points_at(base, None, 0.0, [-1e-6, 1e-6], False)
    assert before is not None and before.tangent @ ev.tangent > 0
    k = min(before.eq.wrinkled_stiffness)
    # K falls by 4.8e-5 per 1e-6 of arclength here: 1e-6 before the end it is 4.8e-5
    assert 0 < k < 1e-4
    assert after is None
