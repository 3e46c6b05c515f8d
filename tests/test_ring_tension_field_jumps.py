"""Ring electrodes (R/A 0.2 to 0.8, two-layer passive regions) on a tension-field scene of three zones (audit
helper-48, scenes r28_p20 … r28_p22, r49_p26): where the homogeneous state splits, the jump's gradient flow ran on
a zone curve whose states jump at one pole stretch (1.65068 at 22 mbar: wrinkled fraction 0 -> 0.6, volume 3.49 ->
20.76), so its spline rang with false volume folds; the flow snapped on one and ended where no exact state is
(exit 1 "the flow ended on 2 of 3 bulged, which is not stable", or "did not settle (stalled)" at 20 mbar). The
jump's curve now ends at the jump, and the ramp ends with ``no_stable_state`` at the split, at the voltage where
the same scene with wrinkling refused ends (its zones are taut up to there), naming the jump. ``equilibria_at``
there lists only the (unstable) homogeneous and 2-of-3 states.

``Simulation.coexistence`` no longer loses every stable range when a jump of its preliminary ramp fails."""

import re

import numpy as np
import pytest
from conftest import ring_scene

from coexist import load_scene
from coexist.errors import SolverError
from coexist.ramp import Ramp
from coexist.simulation import Simulation


def _sim(tmp_path, wrinkling):
    path = tmp_path / f"r28_{wrinkling}.toml"
    path.write_text(ring_scene(wrinkling, "r28_p22", 0.2, 0.8, 3, 22, "[0, 4.9, 4.95]"), encoding="utf-8")
    return Simulation.from_scene(load_scene(str(path)))


def _lost(report):
    ts = [t for t in report.result.transitions if t.kind == "no_stable_state"]
    assert len(ts) == 1, [(t.kind, t.reason) for t in report.result.transitions]
    return ts[0]


def test_split_on_tension_field_ring_ends_with_no_stable_state(tmp_path):
    sim = _sim(tmp_path, "tension-field")
    report = sim.ramp()  # raised SolverError (the flow ended on 2 of 3 bulged) before
    t = _lost(report)
    assert t.from_label == "homogeneous" and t.to_label == "none" and t.event == "split"
    lam_jump = float(re.search(r"the states jump at pole stretch ([0-9.]+)", t.reason).group(1))
    # the states before the split are taut: the same split as the scene that refuses wrinkling (to 1e-8 in Φ̂),
    # whose zone curve ends where the tension-field one jumps (the ring's hoop tension vanishing), to 1e-4
    refused = _lost(_sim(tmp_path, "refuse").ramp())
    assert t.phi_hat == pytest.approx(refused.phi_hat, rel=1e-8)
    lam_refused = float(re.search(r"wrinkling beyond pole stretch ([0-9.]+)", refused.reason).group(1))
    assert lam_jump == pytest.approx(lam_refused, abs=1e-4)
    assert lam_jump == pytest.approx(1.65068, abs=1e-4)
    assert float(sim.scene.voltage_of(t.phi_hat)) / 1e3 == pytest.approx(4.918692907, abs=1e-8)
    # 0 and 4.9 kV homogeneous (finite states), 4.95 kV past the split: no state
    steps = report.result.steps
    assert [s.state is not None for s in steps] == [True, True, False]
    assert all(np.isfinite(s.state.p_hat) for s in steps[:2])
    # nothing stable at the split voltage among the exact equilibria the curve's candidates converge to
    assert not any(e.stable for e in sim.equilibria_at(t.phi_hat * (1 + 1e-5)))


def test_coexistence_survives_a_failed_jump_of_its_ramp(tmp_path, monkeypatch):
    sim = _sim(tmp_path, "tension-field")

    def failing_jump(self, seg, end, direction):
        raise SolverError(f"jump from {seg.label} at Φ̂ = {end.phi_hat:.10g}: test failure")

    monkeypatch.setattr(Ramp, "jump", failing_jump)
    entries = sim.coexistence([1])  # raised SolverError before
    assert [e.k for e in entries] == [1]
    assert "the ramp over the window stopped (jump from homogeneous" in entries[0].note
    assert "test failure" in entries[0].note
    # the homogeneous segment the ramp traced before the failure stays in the map, up to its split
    homog = [s for s in sim.emap.segments if s.label == "homogeneous"]
    assert homog and float(sim.scene.voltage_of(homog[0].end_phi(+1))) / 1e3 == pytest.approx(4.918692907, abs=1e-8)
