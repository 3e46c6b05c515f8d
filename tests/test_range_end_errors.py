"""Range ends of the ramp: located on the event they are (not on a probe that failed on its way there), with
the error they really have, and never a numerical failure listed as a physical end.

- A 3000 ml chamber: the bulged zone's wrinkled band pulls in. A loose probe 4e-5 (arclength) before the
  pull-in failed on a Newton iterate past it, and the end had been put there (4.306315 kV, stiffness still
  1.7e-3): its re-location at rtol/100 found the real end 6e-5 kV further, the error 1.2e-4 kV.
- A chamber closed at 0.5 mbar: the homogeneous zones' pole tension falls to zero at 4.9049127 kV; the states
  before it need ever more integration steps, and the end had been the step budget (``solver_budget``).
"""

import pytest
from conftest import variant

import coexist.continuation as continuation
from coexist import Simulation, SolverSettings
from coexist.errors import SolverError


def _end(scene, rtol):
    sim = Simulation.from_scene(scene, SolverSettings(rtol=rtol))
    report = sim.ramp()
    (t,) = [t for t in report.result.transitions if t.kind == "no_stable_state"]
    return t, report


def test_pull_in_end_of_a_large_chamber_is_located_with_its_real_error():
    scene = variant(volume_ml=3000)
    t, report = _end(scene, 1e-10)
    t_high, report_high = _end(scene, 1e-12)
    kv, err = report.voltage_kV(t.phi_hat), report.voltage_kV(t.phi_hat_error)
    kv_high = report_high.voltage_kV(t_high.phi_hat)
    assert t.source.note.startswith("electromechanical_instability: a wrinkled")
    assert t.measured
    # the error is measured and small (old code: 1.2e-4 kV), and the value agrees with rtol 1e-12 within it
    assert err < 1e-7
    assert abs(kv - kv_high) <= err
    # the pull-in itself (old code: 4.306315005 kV, a state whose wrinkled stiffness was still 1.7e-3)
    assert abs(kv_high - 4.30637592) < 1e-7
    # the state kept as the end's is the last one the extrapolation used, 8e-6 kV before it (old: 1.7e-3)
    assert min(t.source.eq.wrinkled_stiffness) < 5e-4


def test_step_budget_end_is_the_physical_end_it_hides():
    scene = variant(closing_pressure_mbar=0.5)
    t, report = _end(scene, 1e-10)
    # not the step budget (old code: 'solver_budget' at 4.904912505 kV) but the pole's tension reaching zero
    assert not t.source.note.startswith("solver_budget")
    assert t.source.note.startswith("wrinkling: the tension at the pole")
    # the states just before it need ever more integration steps (52 843 at 1e-9 in Φ̂ from it, rtol 1e-10): the
    # probes that run out of steps are passed over, and the end is bracketed by the last valid state and the first
    # probe whose pole tension is not positive, the error measured by locating it again at rtol 1e-12 (whose
    # states run out of steps further from it). The code before raised the budget 64-fold to close the bracket to
    # 9e-10 kV (15 s), printed "not measured"; that location (4.904912727 kV, whole ramp at 64 000 steps) moved by
    # 5e-8 kV with a 5e-12 change of the pressure maximum's pole stretch. It lies within the measured error
    kv, err = report.voltage_kV(t.phi_hat), report.voltage_kV(t.phi_hat_error)
    assert t.measured
    assert abs(kv - 4.904912727) <= err
    assert 1e-7 < err < 1e-4
    # the end's state is valid: its pole tension is positive, and the voltage is below the high-budget location
    (l0,) = t.source.eq.pole_stretch  # one group: the homogeneous zones
    model = Simulation.from_scene(scene).model
    assert float(model.pole(l0, t.phi_hat)[0]) > 0
    assert kv < 4.904912727


def test_the_bracket_of_a_budget_end_grows_as_the_budget_shrinks():
    # the same end with 100 and 400 integration steps per trajectory (no larger budget allowed): the bracket is
    # wider, the location further from the high-budget one, and still within its measured error
    monkey = pytest.MonkeyPatch()
    monkey.setattr(continuation, "BUDGET_ESCALATION_MAX", 1)
    try:
        errors = []
        for steps in (100, 400):
            sim = Simulation.from_scene(variant(closing_pressure_mbar=0.5), SolverSettings(rtol=1e-10, max_steps=steps))
            report = sim.ramp()
            (t,) = [t for t in report.result.transitions if t.kind == "no_stable_state"]
            kv, err = report.voltage_kV(t.phi_hat), report.voltage_kV(t.phi_hat_error)
            assert t.source.note.startswith("wrinkling: the tension at the pole")
            assert t.measured and abs(kv - 4.904912727) <= err
            errors.append(err)
        assert errors[0] > 1e-4  # 100 steps: 5.9e-4 kV
    finally:
        monkey.undo()


def test_step_budget_that_reaches_no_physical_end_is_a_solver_error(monkeypatch):
    # no larger budget allowed, and no probe beyond the valid states fails for a physical reason (here: the pole's
    # failure read as running out of steps): the end is a numerical failure, raised (the CLI exits 1), never a
    # transition
    from coexist.shooting import STEP_LIMIT, WRINKLED_AT_POLE

    code_of = continuation._code_of
    monkeypatch.setattr(continuation, "BUDGET_ESCALATION_MAX", 1)
    monkeypatch.setattr(
        continuation, "_code_of", lambda p, e: STEP_LIMIT if code_of(p, e) == WRINKLED_AT_POLE else code_of(p, e)
    )
    sim = Simulation.from_scene(variant(closing_pressure_mbar=0.5), SolverSettings(rtol=1e-10))
    with pytest.raises(SolverError, match=r"step budget.*Φ̂ = 0\.298|Φ̂ = 0\.298.*step budget"):
        sim.ramp()
