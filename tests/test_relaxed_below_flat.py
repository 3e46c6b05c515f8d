"""The relaxed (tension-field) patterned solver below the flat zone's pole stretch: ``BELOW_FLAT``, as the taut one.

The zone of tests/test_pattern_below_flat.py (a one-layer electrode disc in a three-layer passive annulus, Gent 97,
prestretch 1.2: unpressurised, the annulus pulls the disc open to a pole stretch of 1.4151 at Φ̂ = 0.1), on a
tension-field membrane, solved by :func:`coexist.patterned_relaxed.solve_patterned_relaxed` directly. Below the flat
pole stretch its secant iteration on the interface scale used to go on below the pole's series radius (to scales
~1e-5, the pole region integrated backwards) and end in ``solver_budget`` after ~24000 steps, or creep down for all
its iterations and end ``not_finite``. The flat zone is the independent 1-D radial solve of that file (scipy)."""

import re

import numpy as np
import pytest
from test_pattern_below_flat import FRACTION, LAYERS, PHI, _flat_annulus, _flat_pole_stretch

import coexist.patterned_relaxed as pr
from coexist import shooting
from coexist.model import build_model
from coexist.patterned import SCALE_FLOOR, ZonePattern, solve_patterned_states
from coexist.patterned_relaxed import solve_patterned_relaxed
from coexist.shooting import OK, REASONS, reason_tag


@pytest.fixture(scope="module")
def zone():
    taut = build_model("gent", jlim=97.0, voltage=True, prestretch=1.2)
    relaxed = build_model("gent", jlim=97.0, voltage=True, prestretch=1.2, wrinkling="tension-field")
    return taut, relaxed, ZonePattern.inner_circle(FRACTION, LAYERS)


@pytest.fixture
def trials(monkeypatch):
    """Every relaxed pass's interface scales, with the pole's series radius over the first fraction."""
    seen = []
    original = pr._relaxed_pass

    def recording(model, settings, lay, l0, p_t, sigma, pole, stops=None):
        seen.append((np.array(sigma, dtype=float), np.log(np.asarray(pole[5], dtype=float) / lay.f[0])))
        return original(model, settings, lay, l0, p_t, sigma, pole, stops)

    monkeypatch.setattr(pr, "_relaxed_pass", recording)
    return seen


@pytest.mark.parametrize("l0", [1.212, 1.3, 1.40814])
def test_below_the_flat_zone_is_below_flat_in_few_steps(zone, trials, l0):
    """Status BELOW_FLAT (tag ``no_equilibrium``, not ``solver_budget`` nor ``not_finite``) in a few hundred
    steps; no scale tried puts the first interface nearer the pole than SCALE_FLOOR series radii; the clamp
    stretch is reached where the independent flat zone reaches it, and where the taut solver says."""
    taut_model, model, pattern = zone
    assert l0 < _flat_pole_stretch(taut_model)
    st = solve_patterned_relaxed(model, pattern, [l0], PHI)
    assert st.status[0] == shooting.BELOW_FLAT, st.failure_detail[0]
    assert reason_tag(st.status[0]) == "no_equilibrium"
    assert st.failure_detail[0].startswith(REASONS[shooting.BELOW_FLAT][1])
    assert st.steps[0] < 2000  # it was ~24000 (solver_budget) at 1.212 and 1.3
    assert trials and all(np.all(s >= lnr + np.log(SCALE_FLOOR) - 1e-12) for s, lnr in trials)
    reach = float(re.search(r"reached at ([0-9.]+) of the rim radius", st.failure_detail[0]).group(1))
    assert abs(reach - float(_flat_annulus(taut_model, l0, True).t_events[0][0])) < 2e-5
    taut = solve_patterned_states(taut_model, pattern, [l0], PHI)
    assert taut.status[0] == shooting.BELOW_FLAT
    assert reach == float(re.search(r"reached at ([0-9.]+) of the rim radius", taut.failure_detail[0]).group(1))


def test_above_the_flat_zone_unchanged(zone):
    """Just above the flat pole stretch the relaxed state is the taut one (no wrinkles): the floor is not in the
    way."""
    taut_model, model, pattern = zone
    l0 = [1.42, 1.5]
    st = solve_patterned_relaxed(model, pattern, l0, PHI)
    taut = solve_patterned_states(taut_model, pattern, l0, PHI)
    assert np.all(st.status == OK) and np.all(taut.status == OK)
    assert np.allclose(st.p_hat, taut.p_hat, rtol=1e-8)
