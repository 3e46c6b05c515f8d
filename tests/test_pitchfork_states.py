"""A path voltage just past a symmetric branch point (supercritical pitchfork) at high accuracy: two zones on
one chamber, the radius fitted so that the continuous split is at 3.9 kV. At rtol 1e-12, 3.9 kV lies 1.6e-11
in Φ̂ above the branch point (located to 1e-16), outside its uncertainty, where Newton's method at fixed
voltage on the split configuration is singular; the ramp used to exit 1 there ("no converged state")."""

import numpy as np
import pytest
from conftest import variant

from coexist.equilibria import shoot_groups
from coexist.scene import load_scene
from coexist.settings import SolverSettings
from coexist.simulation import Simulation

SCENE = """
name = "pitchfork"
[membrane]
material = "gent"
jlim = 97
shear_modulus_kPa = 45
relative_permittivity = 4.7
thickness_mm = 0.5
zone_radius_mm = 21.386364016105813
prestretch = 1.0
wrinkling = "tension-field"
[zones]
count = 2
[chamber]
volume_ml = 300
closing_pressure_mbar = 20
atmospheric_pressure_kPa = 101.325
[voltage]
values_kV = [3.9, 3.92, 5.0, 3.92, 3.9, 3.88]
"""


def test_split_state_next_to_the_pitchfork_at_high_accuracy(tmp_path):
    """The 3.9 kV down state is the split one (x = u2 − u1 > 0, as on the segment), with c·x² = Φ̂ − Φ̂bp
    to 1e-3 relative (c from the segment's traced point nearest the branch point, x ≈ 6e-3: its own
    x⁴ term is 5e-4 relative), stable, and a converged solution of the exact equations at exactly 3.9 kV:
    the pressure balance and the equal pressures of the two zones below residual_tol (1 + |p̂|)."""
    path = tmp_path / "scene.toml"
    path.write_text(SCENE)
    settings = SolverSettings.from_accuracy("high")
    sim = Simulation.from_scene(load_scene(path), settings=settings)
    rep = sim.ramp()
    steps = rep.result.steps
    down = steps[4]
    assert down.state is not None
    eq = down.state
    assert eq.configuration.counts == (1, 1)
    assert eq.stable
    merge = rep.result.transitions[[t.kind for t in rep.result.transitions].index("merge")]
    phi_bp = merge.phi_hat
    delta = eq.phi_hat - phi_bp
    assert delta == pytest.approx(1.6e-11, rel=0.05)  # outside the branch point's uncertainty (~1e-16)
    seg = sim.emap.segment_of(eq, eq.zone_index)
    near = min(seg.points, key=lambda p: abs(p.phi - phi_bp))
    x_near = near.z[1] - near.z[0]
    c = (near.phi - phi_bp) / x_near**2
    u = np.sqrt(np.asarray(eq.pole_stretch) - 1.0)
    x = u[1] - u[0]
    assert x > 0 and x_near > 0  # the segment's orientation (the bulged zone second)
    assert c * x**2 == pytest.approx(delta, rel=1e-3)
    assert x == pytest.approx(1.5303e-5, rel=1e-3)
    assert any("symmetric branch point" in n and "split" in n for n in eq.notes)
    # the exact equations at exactly the path voltage (a fresh evaluation, not the solver's own)
    system = seg.tracer.system
    res = system.residual(u[None], np.array([eq.phi_hat]))
    tol = settings.residual_tol * (1 + abs(float(res.gas_pressure[0])))
    assert abs(res.r[0, 0]) < tol  # p̂(u1) = p̂_gas
    st = shoot_groups(system.model, u[None], np.array([eq.phi_hat]), settings)
    assert abs(st.p[0, 1] - float(res.gas_pressure[0])) < tol  # p̂(u2) = p̂_gas
    # the pair's row, (p̂2 − p̂1)/x: its divided difference is rounding, about 10 ε |p̂| / x (2e-10 at most)
    assert abs(res.r[0, 1]) < 20 * np.finfo(float).eps * abs(st.p[0, 0]) / x
    assert eq.residual < tol  # the pair's row by quadrature of the exact slopes (the solver's)
    assert rep.voltage_kV(eq.phi_hat) == pytest.approx(3.9, abs=1e-12)  # the path voltage (unit rounding)


def test_a_path_next_to_a_pitchfork_and_a_fold_at_once():
    """Two zones on the path [0, 3.85215522, 4.10604894, 0] kV: 7e-9 kV above the symmetric branch point and 1e-8 kV
    below the bulged branch's fold, both on one stable segment. Solved in one batch, the row next to the pitchfork
    kept the one next to the fold on full Newton steps (the corrector switches to chord steps for a whole batch),
    which stop at the shooting's noise there and were taken to diverge: the ramp ended in an error although each
    voltage alone converges (found in review). The state at 4.10604894 kV is the stable one next to the fold that
    ``equilibria_at`` finds independently."""
    scene = variant(count=2, values_kV="[0, 3.85215522, 4.10604894, 0]")
    sim = Simulation.from_scene(scene)
    report = sim.ramp()
    (near_fold,) = [s for s in report.result.steps if abs(report.voltage_kV(s.phi_hat) - 4.10604894) < 1e-9]
    assert near_fold.state is not None and near_fold.state.configuration.counts == (1, 1)
    stable = [e for e in sim.equilibria_at(near_fold.phi_hat) if e.stable and e.configuration.counts == (1, 1)]
    # 1e-8 kV below a fold a state is ill-conditioned (λ0 moves like the square root of the distance): two converged
    # states differ by ~2e-7 there; the other stable pair of this configuration lies 0.2 and 2.4 away
    assert near_fold.state.residual <= sim.settings.residual_tol * (1 + near_fold.state.p_hat)
    assert any(np.allclose(e.pole_stretch, near_fold.state.pole_stretch, rtol=1e-5) for e in stable), (
        near_fold.state.pole_stretch,
        [e.pole_stretch for e in stable],
    )
