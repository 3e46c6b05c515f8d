"""The pull-in of a wrinkled band: the quantity it is located by, and where the located end lies.

At the default scene's pull-in (docs/physics.md, section 10) the wrinkled band of the bulged zone ends where
the stiffness along the natural width, ``K = dT̂1ʷ/dλ1``, vanishes. Each shot records ``K/T̂11`` at the outer
end of its bands (``MembraneStates.wrinkled_stiffness``), and the continuation extrapolates its zero
(``Tracer.pull_in_end``).
"""

import numpy as np
import pytest

from coexist.effects import Gent, IdealDielectric
from coexist.model import MembraneModel
from coexist.settings import SolverSettings
from coexist.shooting import solve_states
from coexist.studies.wrinkled_shooting import shoot_relaxed
from coexist.wrinkling import natural_width

MODEL = MembraneModel(Gent(97.0), IdealDielectric(), 1.0, wrinkling="tension-field")


@pytest.fixture(scope="module")
def tricircle():
    from coexist.scene import load_scene
    from coexist.simulation import Simulation

    sim = Simulation.from_scene(load_scene("tricircle"))
    return None, sim, sim.ramp()


@pytest.mark.parametrize("l0", [5.826, 5.8272, 5.8275])
def test_band_end_stiffness_matches_an_independent_shot(l0):
    """``wrinkled_stiffness`` of the vectorised shooting equals ``K/T̂11`` at the end of the wrinkled segment
    of scipy's one-state shooting (``coexist.studies.wrinkled_shooting``, rtol 1e-12), evaluated there from
    the model's tensions and the natural width; to 1e-7 absolute (K/T̂11 here is 1e-4 … 3e-2)."""
    phi = 0.26375
    st = solve_states(MODEL, [l0], phi, SolverSettings(rtol=1e-10)).require_ok()
    ref = shoot_relaxed(MODEL, l0, phi, rtol=1e-12)
    assert ref.status == "ok"
    seg = next(s for s in ref.segments if s["kind"] == "wrinkled")
    l1 = seg["solution"](seg["R"][1])[0]
    w = natural_width(MODEL, np.array([l1]), phi)
    T11 = MODEL.tensions(np.array([l1]), w, phi)[2]
    K = MODEL.wrinkle_aux(np.array([l1]), w, phi)[1]
    expected = float(np.squeeze(K / T11))
    assert 0 < expected < 0.05
    assert float(st.wrinkled_stiffness[0]) == pytest.approx(expected, abs=1e-7)


def test_taut_states_carry_infinite_band_stiffness():
    st = solve_states(MODEL, [1.5, 2.5], 0.1)
    assert np.all(st.wrinkled_stiffness == np.inf)
    assert solve_states(MembraneModel(Gent(97.0), IdealDielectric()), [1.5], 0.1).wrinkled_stiffness is None


def test_located_pull_in_separates_states_from_none(tricircle):
    """Along the path's tangent at the located end, a state exists 1e-6 (arclength) before it and none 1e-6
    beyond it (each corrected tightly): the extrapolated end lies inside that bracket, ``Φ̂`` ± 1e-7."""
    _, sim, report = tricircle
    end = next(t for t in report.result.transitions if t.kind == "no_stable_state")
    ev = end.source
    tracer = sim.emap.tracer(end.source_counts)
    from coexist.continuation import Point

    M = tracer.M
    base = Point(ev.z.copy(), ev.tangent, ev.eq, np.zeros(M), np.zeros(M), (0,) * M, True)
    before, beyond = tracer._points_at(base, None, 0.0, [-1e-6, 1e-6], False)
    assert before is not None and min(before.eq.wrinkled_stiffness) > 0
    assert beyond is None or not beyond.tangent @ ev.tangent > 0
    assert abs(before.phi - end.phi_hat) < 1e-7


def test_states_just_below_the_pull_in_converge():
    """A voltage 1e-6 kV below the located pull-in has its state (the branch keeps the extrapolation's tight
    states, so the corrector starts next to it; from the last regular point it stepped past the end and failed)."""
    import json

    from click.testing import CliRunner

    from coexist.cli.main import cli

    r = CliRunner().invoke(cli, ["shape", "tricircle", "--voltage-kV", "4.33662,4.336628", "--json"])
    assert r.exit_code == 0, r.output
    data = json.loads(r.stdout)
    bulged = [g for step in data["voltages"] for g in step["groups"] if g["wrinkled_radii"]]
    assert len(bulged) == 2 and all(0.22 < g["wrinkled_radii"][0][0] < 0.25 for g in bulged)
    assert all(len(g["profile"]["r_mm"]) > 10 for g in bulged)


def test_the_state_before_the_pull_in_carries_its_own_slopes(tricircle):
    """The pull-in's extrapolation corrects its tight states by chord steps (the Jacobian of an earlier iterate),
    then evaluates the state it keeps as the end's once more with derivatives: the state reported before the
    pull-in has the ``dp̂/dV̂`` of a fresh shot with derivatives at its own pole stretches. Measured: 3e-15 relative
    (3.6e-5 before that last evaluation). Asserted: 1e-8."""
    _, sim, report = tricircle
    end = next(t for t in report.result.transitions if t.kind == "no_stable_state")
    eq = end.state_before
    st = solve_states(sim.model, list(eq.pole_stretch), eq.phi_hat, sim.settings, derivatives=True).require_ok()
    fresh = st.derivatives.dp_dl0 / st.derivatives.dv_dl0
    np.testing.assert_allclose(np.asarray(eq.dp_dv), fresh, rtol=1e-8, atol=0)
