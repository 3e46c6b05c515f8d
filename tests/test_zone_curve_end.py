"""A zone curve whose states end at a failure inside its grid (pull-in, wrinkling) reaches the last valid state
near that end (coexist.zone_curves._refined_end): equilibria near the end of a bulged zone's states are found
from it. On the default scene at 4.32-4.33 kV the bulged zone sits between the last valid grid point of the
zone curve and the pull-in that ends it; `Simulation.equilibria_at` missed that stable state (audit of
2026-12-01). Checked against the ramp, which reaches it by continuation (an independent path)."""

import numpy as np
import pytest

from coexist import Simulation, SolverSettings, load_scene
from coexist.shooting import solve_states
from coexist.zone_curves import ZoneCurve


@pytest.fixture(scope="module")
def sim():
    return Simulation.from_scene(load_scene("tricircle"), SolverSettings(error_estimates=False))


def _grid(sim):
    pre = sim.model.prestretch
    u = np.linspace(np.sqrt(1e-3 * pre), np.sqrt(sim.lam_max - pre), sim.settings.zone_curve_points)
    return pre + u**2


def test_the_curve_reaches_past_its_last_grid_point(sim):
    """At Φ̂(4.33 kV) the grid's run ends at a pull-in; the refined curve ends at a valid state within 1/729 of a
    grid spacing below a failed one (shot again here), past the grid's last valid point."""
    phi = float(sim.scene.phi_hat(4330.0))
    grid = _grid(sim)
    st = solve_states(sim.model, grid, phi, sim.settings)
    last = int(np.flatnonzero(~st.ok)[np.flatnonzero(~st.ok) > np.argmax(st.ok)][0]) - 1
    curve = ZoneCurve.compute(sim.model, phi, grid, sim.settings)
    end = float(curve.to_stretch(curve.span[1]))
    spacing = grid[last + 1] - grid[last]
    assert grid[last] < end < grid[last + 1]
    again = solve_states(sim.model, [end, end + spacing / 729 * (1 + 1e-6), grid[last + 1]], phi, sim.settings)
    assert again.ok[0] and not again.ok[1] and not again.ok[2]
    assert curve.stopped_because.startswith("electromechanical_instability") or "beyond pole stretch" in (
        curve.stopped_because or ""
    )


def test_equilibria_at_finds_the_ramps_bulged_state(sim):
    """The ramp's state at 4.32 kV (one zone bulged, its pole stretch past the grid's last valid point) is among
    `equilibria_at` 4.32 kV, stable, the same to 1e-8 in every zone's pole stretch; at 4.33 kV a stable one
    of one bulged zone is found too."""
    report = sim.ramp()
    target = float(sim.scene.phi_hat(4320.0))
    (step,) = [s for s in report.result.steps if s.direction == "up" and abs(s.phi_hat - target) < 1e-12]
    assert step.state is not None and step.state.k == 1
    grid = _grid(sim)
    st = solve_states(sim.model, grid, target, sim.settings)
    run_end = grid[np.argmax(~st.ok[np.argmax(st.ok) :]) + np.argmax(st.ok) - 1]
    assert max(step.state.pole_stretch) > run_end  # the state lies beyond the grid's valid run
    eqs = sim.equilibria_at(target)
    same = [
        e
        for e in eqs
        if e.configuration == step.state.configuration
        and np.allclose(e.pole_stretch, step.state.pole_stretch, rtol=1e-8, atol=0)
    ]
    assert len(same) == 1 and same[0].stable
    stable_bulged = [e for e in sim.equilibria_at(float(sim.scene.phi_hat(4330.0))) if e.stable and e.k == 1]
    assert len(stable_bulged) == 1
