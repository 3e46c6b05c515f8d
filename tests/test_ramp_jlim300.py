"""A path voltage just inside a fold that ends a stable segment (helper-42): the Gent tricircle at Jlim = 300.

At Jlim = 300 the one-of-three-bulged configuration has two stable branches (``coexist coexistence``, rtol
1e-10, errors ±2e-9 kV): the near one from its fold at 0.940156826 kV to its fold at 2.220508500 kV, the far
one from its fold at 2.156831049 kV to the pull-in at 2.49213507 kV (± 1e-8). The default path's 2.22 kV lies
5e-4 kV below the near branch's fold, past the segment's last traced point (2.2144 kV). The old code predicted
the state there by extrapolating the segment's last Hermite piece past that point: across the fold, onto the
unstable side, from where Newton's method at fixed voltage (its matrix nearly singular) left the physical range
and the ramp ended with "no converged state at Φ̂ = 0.1350205918 on its stable segment (invalid state: the
pole stretch left the physical range (λ0 ≤ λpre))". Coming down on the far branch to 2.1569 kV (7e-5 kV above
its fold) the same extrapolation converged on the unstable partner state and the ramp printed it. Now the fold
(its state and tangent) is the segment's end node: the prediction stays on the stable side.
"""

import numpy as np
import pytest
from conftest import bounded, variant

from coexist.errors import SolverError
from coexist.settings import SolverSettings
from coexist.simulation import Simulation

#: the one-of-three-bulged stable ranges' ends (kV) by ``coexist coexistence`` at rtol 1e-10
NEAR_FOLD_KV = 2.220508500
FAR_FOLD_KV = 2.156831049
PULL_IN_KV = 2.49213507
#: the split of the homogeneous state on the ramp up (kV, ``coexist ramp``, ± 2e-9)
SPLIT_KV = 1.489197677


def _ramp(path_kV: str):
    sim = Simulation.from_scene(variant(jlim=300, values_kV=path_kV), SolverSettings(rtol=1e-10))
    return sim, bounded(sim.ramp)


def _u(eq) -> np.ndarray:
    """The groups' ``u = √(λ0 − λpre)`` (λpre = 1), ascending."""
    return np.sort(np.sqrt(np.asarray(eq.pole_stretch) - 1.0))


def _is_the_stable_state(sim, eq) -> None:
    """``eq`` is one of the stable equilibria the independent search at its voltage finds (``u`` to 1e-6; a
    state 7e-5 kV from a fold is known to about 1e-7 in ``u`` at rtol 1e-10) and none of the unstable ones."""
    found = sim.equilibria_at(eq.phi_hat)
    same = [e for e in found if e.label == eq.label and np.max(np.abs(_u(e) - _u(eq))) < 1e-6]
    assert len(same) == 1 and same[0].stable, [(e.label, e.stable, _u(e)) for e in found]
    assert eq.stable


def test_the_ramp_reaches_a_state_just_below_the_near_fold():
    try:
        sim, rep = _ramp("[0, 2.22]")
    except SolverError as exc:  # the old code
        pytest.fail(f"the ramp failed at a voltage where a stable state exists: {exc}")
    steps = {round(float(rep.voltage_kV(s.phi_hat)), 6): s for s in rep.result.steps}
    top = steps[2.22].state
    assert top is not None and top.label == "1 of 3 bulged"
    _is_the_stable_state(sim, top)
    # the near branch: the bulged group at u = 2.0799335 (the fold's is 2.1067571), the two others 0.6251676
    np.testing.assert_allclose(_u(top), [0.6251676, 2.0799335], atol=1e-6)
    (split,) = [t for t in rep.result.transitions if t.kind == "spinodal"]
    assert abs(rep.voltage_kV(split.phi_hat) - SPLIT_KV) < 1e-8  # measured error 2e-9 kV


def test_coming_down_just_above_the_far_fold_the_state_is_the_stable_one():
    sim, rep = _ramp("[2.5, 2.1569]")
    kinds = [(t.kind, t.direction) for t in rep.result.transitions if t.kind != "equal_free_energy"]
    assert kinds == [("spinodal", "up"), ("spinodal", "up"), ("no_stable_state", "up"), ("re_entry", "down")]
    fold_up, end = rep.result.transitions[1], rep.result.transitions[2]
    assert abs(rep.voltage_kV(fold_up.phi_hat) - NEAR_FOLD_KV) < 1e-8  # measured error 2e-9 kV
    assert abs(rep.voltage_kV(end.phi_hat) - PULL_IN_KV) < 5e-8  # measured error 1e-8 kV
    steps = {(round(float(rep.voltage_kV(s.phi_hat)), 6), s.direction): s for s in rep.result.steps}
    low = steps[(2.1569, "down")].state
    assert low is not None and low.label == "1 of 3 bulged"
    _is_the_stable_state(sim, low)
    # the far branch's stable state (the unstable partner just past the fold: 0.5768602, 2.6603184)
    np.testing.assert_allclose(_u(low), [0.5746578, 2.6788939], atol=1e-6)
    assert abs(rep.voltage_kV(low.phi_hat) - FAR_FOLD_KV) < 1e-4  # indeed just above the fold
