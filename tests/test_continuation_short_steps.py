"""The continuation crosses what its event functions do not locate with short steps, and a split is pushed both
ways when one way lands on no stable state.

The onset of wrinkling of a zone group is crossed with a short step. A tricircle on a 30 l chamber
(100× the paper's): its bulged zone pulls in just past its onset of wrinkling, near 4.03 kV. A long step (Φ̂ 0.229
→ 0.286) had crossed the onset and landed on a wrinkled state of another branch (the unbulged zones' pole stretch
1.28 → 1.10); the segment then held voltages with no state, `coexist ramp` failed ("no converged state ... on its
stable segment") and `coexist coexistence` called the configuration stable to the top of the window (5 kV)."""

import numpy as np
import pytest

from coexist.scene import builtin_scene_text, parse_scene
from coexist.simulation import Simulation


@pytest.fixture(scope="module")
def big_chamber():
    text = builtin_scene_text("tricircle").replace("volume_ml = 300\n", "volume_ml = 30000\n")
    assert "volume_ml = 30000" in text
    return parse_scene(text)


def test_the_ramp_ends_at_the_pull_in_and_agrees_with_coexistence(big_chamber):
    report = Simulation.from_scene(big_chamber).ramp()
    kinds = [t.kind for t in report.result.transitions]
    assert kinds[:3] == ["spinodal", "no_stable_state", "re_entry"], kinds
    end = report.result.transitions[1]
    assert report.voltage_kV(end.phi_hat) == pytest.approx(4.0299123, abs=1e-5)
    (entry,) = Simulation.from_scene(big_chamber).coexistence(bulged=[1])
    # the coexistence table's stable range of one bulged zone ends where the ramp's segment ends (not at 5 kV)
    tops = [seg.phi_range[1] for seg in entry.segments]
    assert any(top == pytest.approx(end.phi_hat, abs=1e-8) for top in tops), (tops, end.phi_hat)
    assert report.voltage_kV(max(tops)) < 4.1


def test_the_states_of_the_bulged_segment_are_continuous_up_to_its_end(big_chamber):
    sim = Simulation.from_scene(big_chamber)
    report = sim.ramp()
    rows = [s for s in report.result.steps if s.state is not None and "1 of 3" in s.state.label]
    assert len(rows) > 10
    lam = np.array([min(s.state.pole_stretch) for s in rows])
    # the unbulged zones' pole stretch changes smoothly from voltage to voltage (a jump of 0.18 before)
    assert np.max(np.abs(np.diff(lam))) < 0.02, np.max(np.abs(np.diff(lam)))


def test_a_1000_litre_chamber_ramps_through_its_splits_and_back():
    """Near pressure control (1000 l): on the way down the all-bulged homogeneous state splits at Φ̂ = 0.034; its
    mode pushed one way the gradient flow stalled on a saddle (an unstable 2 + 1 split), and the ramp failed ("the
    flow ended on 1 of 3 bulged, which is not stable"); pushed the other way it lands on 2 of 3 bulged. Further
    down, a long step had carried the 1-of-3 segment from a stable state (Φ̂ 0.026) to an unstable one past 0 V
    (the bulged zone's pole stretch 4.71 -> 3.79) with no event between: a change of stability without an event
    now shortens the step."""
    text = builtin_scene_text("tricircle").replace("volume_ml = 300\n", "volume_ml = 1000000\n")
    report = Simulation.from_scene(parse_scene(text)).ramp()
    kinds = [t.kind for t in report.result.transitions]
    assert kinds.count("spinodal") == 5, kinds
    up = [round(report.voltage_kV(t.phi_hat), 4) for t in report.result.transitions if t.kind == "spinodal"]
    assert up[:3] == pytest.approx([1.6029, 1.9090, 2.2351], abs=2e-4)
    assert all(s.state is None or s.state.stable for s in report.result.steps)
