"""Exact derivatives of patterned zone states (:func:`coexist.patterned.solve_patterned_states` with
``derivatives=True``): against Richardson finite differences of converged solves, against
:func:`coexist.shooting.solve_states` where the pattern is a uniform zone, and the Maxwell relation.

The finite differences are of converged states at ``rtol = 1e-12``: central differences with steps ``h`` and
``h/2`` combined by Richardson's rule (truncation ``O(h⁴)`` with ``h = 1e-3``: ~1e-12; roundoff
``~1e-12/h``: ~1e-9 at worst), so a relative agreement of 1e-7 leaves a margin of 100 over both, and a wrong
interface term (a missing chain-rule factor ``1/n``, a missing interface motion, a charge counted off the
electrode) is wrong at the percent level.
"""

from __future__ import annotations

import numpy as np
import pytest

from coexist import SolverSettings, solve_states
from coexist.model import MembraneModel, build_model
from coexist.patterned import ZonePattern, solve_patterned_states
from coexist.shooting import OK

TIGHT = SolverSettings(rtol=1e-12)
FIELDS = ("dp_dl0", "dv_dl0", "dq_dl0", "dp_dphi", "dv_dphi", "dq_dphi")
PATTERNS = {
    "inner circle": ZonePattern.inner_circle(0.5),
    "ring": ZonePattern.ring(0.3, 0.7),
    "two-layer passive": ZonePattern.inner_circle(0.6, passive_layers=2),
}
#: (λ0, Φ̂): low and high inflation, low and high voltage (all taut states of the three patterns)
POINTS = ((1.6, 0.1), (2.3, 0.2), (1.3, 0.35), (2.0, 0.0))


@pytest.fixture(scope="module")
def model():
    return MembraneModel()


def _values(model, pattern, l0, phi, settings=TIGHT):
    st = solve_patterned_states(model, pattern, l0, phi, settings)
    assert np.all(st.status == OK), st.failure_detail
    return np.vstack([st.p_hat, st.v_hat, st.q_hat])


def _richardson(fun, x, h):
    """``f'(x)`` from central differences with steps ``h`` and ``h/2``, Richardson-combined (columns: states)."""
    d1 = (fun(x + h) - fun(x - h)) / (2 * h)
    d2 = (fun(x + h / 2) - fun(x - h / 2)) / h
    return (4 * d2 - d1) / 3


@pytest.mark.parametrize("name", list(PATTERNS))
def test_derivatives_match_richardson_differences(model, name):
    pattern = PATTERNS[name]
    l0 = np.array([p[0] for p in POINTS])
    phi = np.array([p[1] for p in POINTS])
    st = solve_patterned_states(model, pattern, l0, phi, TIGHT, derivatives=True)
    assert np.all(st.status == OK), st.failure_detail
    d = st.derivatives
    exact = {
        "l0": np.vstack([d.dp_dl0, d.dv_dl0, d.dq_dl0]),
        "phi": np.vstack([d.dp_dphi, d.dv_dphi, d.dq_dphi]),
    }
    h = 1e-3
    fd_l0 = _richardson(lambda x: _values(model, pattern, x, phi), l0, h)
    # Φ̂ = 0: a central difference would need Φ̂ < 0 (refused); one-sided there (below)
    pos = phi > 0
    fd_phi = np.empty_like(fd_l0)
    fd_phi[:, pos] = _richardson(lambda x: _values(model, pattern, l0[pos], x), phi[pos], h)
    zero = ~pos
    f0 = _values(model, pattern, l0[zero], 0.0)
    f1, f2 = _values(model, pattern, l0[zero], h), _values(model, pattern, l0[zero], 2 * h)
    # Q̂ is odd in Φ̂ (p̂, V̂ even): the one-sided quotient (f(h) − f(0))/h has an O(h²) error, removed by
    # Richardson's rule for h²
    fd_phi[:, zero] = (4 * (f1 - f0) / h - (f2 - f0) / (2 * h)) / 3
    # without voltage there is no charge: Q̂ ≡ 0 and its λ0-derivative is exactly zero
    assert np.all(exact["l0"][2, zero] == 0) and np.all(fd_l0[2, zero] == 0)
    charged = np.ones(fd_l0.shape, dtype=bool)
    charged[2, zero] = False
    rel_l0 = np.abs(exact["l0"] - fd_l0)[charged] / np.abs(fd_l0)[charged]
    assert rel_l0.max() < 1e-7, rel_l0
    scale = np.abs(fd_phi[:, pos])
    rel_phi = np.abs(exact["phi"][:, pos] - fd_phi[:, pos]) / scale
    assert rel_phi.max() < 1e-7, rel_phi
    # at Φ̂ = 0: p̂ and V̂ are even in Φ̂ (their derivatives vanish), the charge's is Q̂/Φ̂ (O(h²) difference)
    assert np.all(np.abs(exact["phi"][:2, zero]) < 1e-12)
    assert np.allclose(exact["phi"][2, zero], fd_phi[2, zero], rtol=1e-7, atol=0)
    assert np.all(np.abs(exact["phi"][2, zero]) > 0.1)


@pytest.mark.parametrize("name", list(PATTERNS))
def test_maxwell_relation_from_the_derivatives(model, name):
    """``∂p̂/∂Φ̂|V̂ = −∂Q̂/∂V̂|Φ̂`` (``dΨ̂ = p̂ dV̂ − Q̂ dΦ̂`` with ``Q̂`` on the electrode only); in ``(λ0, Φ̂)``:
    ``p̂_Φ V̂_λ − p̂_λ V̂_Φ = −Q̂_λ``."""
    l0 = np.linspace(1.3, 2.6, 7)
    st = solve_patterned_states(model, PATTERNS[name], l0, 0.25, TIGHT, derivatives=True)
    assert np.all(st.status == OK)
    d = st.derivatives
    lhs = d.dp_dphi * d.dv_dl0 - d.dp_dl0 * d.dv_dphi
    rel = np.abs(lhs + d.dq_dl0) / np.abs(d.dq_dl0)
    assert rel.max() < 1e-8, rel


def test_split_uniform_zone_has_the_uniform_derivatives(model):
    """A uniform zone cut into regions (nothing jumps, the interfaces still move with ``s``): the
    derivatives of :func:`solve_states`, to the integration's tolerance."""
    l0 = np.linspace(1.3, 2.6, 7)
    split = ZonePattern(((0.3, 1, True), (0.7, 1, True), (1.0, 1, True)))
    a = solve_patterned_states(model, split, l0, 0.25, TIGHT, derivatives=True).derivatives
    b = solve_states(model, l0, 0.25, TIGHT, derivatives=True).derivatives
    for k in FIELDS:
        x, y = getattr(a, k), getattr(b, k)
        assert np.max(np.abs(x - y) / np.abs(y)) < 1e-10, k


@pytest.mark.parametrize("layers", [1, 3])
def test_one_region_patterns_scale_solve_states_derivatives(model, layers):
    """One region of ``n`` layers is the one-layer zone at ``Φ̂/n`` with ``p̂ → n p̂``: its derivatives are
    those of :func:`solve_states` scaled by the chain rule (1e-10), and match differences (1e-7)."""
    l0 = np.array([1.5, 2.2])
    phi = 0.3
    st = solve_patterned_states(model, ZonePattern.full(layers), l0, phi, TIGHT, derivatives=True)
    ref = solve_states(model, l0, phi / layers, TIGHT, derivatives=True).derivatives
    d = st.derivatives
    n = layers
    expected = {
        "dp_dl0": n * ref.dp_dl0,
        "dv_dl0": ref.dv_dl0,
        "dq_dl0": ref.dq_dl0,
        "dp_dphi": ref.dp_dphi,
        "dv_dphi": ref.dv_dphi / n,
        "dq_dphi": ref.dq_dphi / n,
    }
    for k in FIELDS:
        assert np.allclose(getattr(d, k), expected[k], rtol=1e-10, atol=0), k
    fd = _richardson(lambda x: _values(model, ZonePattern.full(layers), l0, x), phi, 1e-3)
    exact = np.vstack([d.dp_dphi, d.dv_dphi, d.dq_dphi])
    assert np.max(np.abs(exact - fd) / np.abs(fd)) < 1e-7
    passive = solve_patterned_states(model, ZonePattern.no_electrode(layers), l0, phi, TIGHT, derivatives=True)
    assert np.all(passive.derivatives.dq_dphi == 0) and np.all(passive.derivatives.dp_dphi == 0)


def test_gent_with_prestretch_matches_differences():
    """A Gent membrane with prestretch (the interface jump and the locking margin away from the neo-Hookean
    case), the inner circle at the paper's voltage."""
    gent = build_model("gent", jlim=97.0, prestretch=1.5)
    pattern = ZonePattern.inner_circle(0.5)
    l0, phi = np.array([2.2, 3.4]), 0.3
    d = solve_patterned_states(gent, pattern, l0, phi, TIGHT, derivatives=True).derivatives
    fd_l0 = _richardson(lambda x: _values(gent, pattern, x, phi), l0, 1e-3)
    fd_phi = _richardson(lambda x: _values(gent, pattern, l0, x), phi, 1e-3)
    exact_l0 = np.vstack([d.dp_dl0, d.dv_dl0, d.dq_dl0])
    exact_phi = np.vstack([d.dp_dphi, d.dv_dphi, d.dq_dphi])
    assert np.max(np.abs(exact_l0 - fd_l0) / np.abs(fd_l0)) < 1e-7
    assert np.max(np.abs(exact_phi - fd_phi) / np.abs(fd_phi)) < 1e-7


def test_failed_states_carry_no_derivatives(model):
    """A state refused (compressed electrode edge at low inflation under voltage, docs/physics.md §12)
    has NaN derivatives and a status; the OK one beside it has finite ones."""
    st = solve_patterned_states(model, ZonePattern.inner_circle(0.5), [1.0192, 1.8], 0.3, derivatives=True)
    assert st.status[0] != OK and st.status[1] == OK
    for k in FIELDS:
        v = getattr(st.derivatives, k)
        assert np.isnan(v[0]) and np.isfinite(v[1])


# --- the N-zone layer: a patterned zone's model is shot region by region everywhere ------------------------

#: the tricircle with an electrode disc over the inner 80 % of each zone's radius (one passive layer around it)
#: and a taut membrane (``refuse``: a patterned zone refuses wrinkled states), ramped up past its split and down
TRICIRCLE_INNER = """
name = "tricircle-inner"
[membrane]
material = "gent"
jlim = 97
shear_modulus_kPa = 45
relative_permittivity = 4.7
thickness_mm = 0.5
zone_radius_mm = 21.4165
prestretch = 1.0
wrinkling = "refuse"
[electrodes]
pattern = "inner-circle"
inner_fraction = 0.8
[zones]
count = 3
[chamber]
volume_ml = 300
closing_pressure_mbar = 20
atmospheric_pressure_kPa = 101.325
[voltage]
values_kV = [0, 3.7, 3.9, 4.1, 3.9, 3.6, 3.3, 0]
"""


@pytest.fixture(scope="module")
def patterned_ramp():
    from coexist.scene import parse_scene
    from coexist.simulation import Simulation

    sim = Simulation.from_scene(parse_scene(TRICIRCLE_INNER))
    return sim, sim.ramp()


def test_a_patterned_scene_ramps_with_equal_pressures_across_zones(patterned_ramp):
    """Every equilibrium of the ramp, its zones re-shot directly with :func:`solve_patterned_states`, holds
    one pressure in all its zones (1e-10), and that pressure is the equilibrium's (1e-9); after the split (at a
    voltage of its own, not the uniform tricircle's 3.900031 kV) one bulged zone coexists with two unbulged."""
    from coexist.patterned import PatternedModel

    sim, report = patterned_ramp
    assert isinstance(sim.model, PatternedModel) and sim.model.pattern == ZonePattern.inner_circle(0.8)
    coexisting = 0
    for step in report.result.steps:
        eq = step.state
        assert eq is not None
        l0 = np.array(eq.pole_stretch)
        direct = solve_patterned_states(sim.model.uniform, sim.model.pattern, l0, eq.phi_hat)
        assert np.all(direct.status == OK)
        # (1e-9: the continuation's states start from its kept neighbours, coexist.patterned.ScaleStarts, so they
        # are not bit for bit the direct cold ones but the same to the integration's tolerance; measured 1.6e-10,
        # from cold starts 1e-14)
        assert np.max(np.abs(direct.p_hat - eq.p_hat)) <= 1e-9 * eq.p_hat, (direct.p_hat, eq.p_hat)
        assert np.allclose(direct.v_hat, eq.v_hat, rtol=1e-9, atol=0)  # (measured 2e-11; cold starts: 1e-12)
        if len(l0) == 2:
            coexisting += 1
            assert l0[1] - l0[0] > 0.5  # bulged and unbulged: far apart on the zone curve
    assert coexisting >= 3
    split = [t for t in report.result.transitions if t.kind == "spinodal" and t.direction == "up"]
    assert len(split) == 1 and split[0].event == "split"
    kv, err = report.voltage_kV(split[0].phi_hat), report.voltage_kV(split[0].phi_hat_error)
    assert err < 1e-7
    assert kv == pytest.approx(3.7997343, abs=1e-6)  # measured; the uniform tricircle splits at 3.900031 kV


def test_the_cli_ramps_a_patterned_scene_with_its_shapes(tmp_path):
    from click.testing import CliRunner

    from coexist.cli.main import cli

    scene = tmp_path / "one.toml"
    # one zone under a controlled pressure, two voltages: the lifted refusal, cheaply
    scene.write_text(
        TRICIRCLE_INNER.replace("count = 3", "count = 1\npressure_mbar = 10")
        .replace("[chamber]\nvolume_ml = 300\nclosing_pressure_mbar = 20\natmospheric_pressure_kPa = 101.325\n", "")
        .replace("values_kV = [0, 3.7, 3.9, 4.1, 3.9, 3.6, 3.3, 0]", "values_kV = [0, 1]")
    )
    runner = CliRunner()
    ok = runner.invoke(cli, ["ramp", str(scene), "--json"])
    assert ok.exit_code == 0, ok.output
    import json

    data = json.loads(ok.stdout)
    assert len(data["steps"]) == 2 and all(s["stable"] for s in data["steps"])
    # --shapes: each zone's profile region by region (coexist.shapes.patterned_profiles), its apex the state's
    shaped = runner.invoke(cli, ["ramp", str(scene), "--shapes", "--json"])
    assert shaped.exit_code == 0, shaped.output
    steps = json.loads(shaped.stdout)["steps"]
    from coexist.scene import load_scene
    from coexist.shapes import patterned_profiles

    sc = load_scene(str(scene))
    for step in steps:
        (group,) = step["shapes"]
        (l0,) = step["pole_stretches"]
        phi = sc.phi_hat(1e3 * step["voltage_kV"])
        prof = patterned_profiles(sc.model(), sc.zone_pattern(), [l0], phi, zone_radius=sc.zone_radius, points=21)[0]
        assert group["apex_height_mm"] == pytest.approx(prof.to_dict()["apex_height_mm"], rel=1e-9)
        assert len(group["profile"]["r_mm"]) >= 21  # the electrode edge among the points


def test_a_patterned_model_takes_tension_field_and_refuses_shapes(model):
    from coexist.errors import SceneError
    from coexist.patterned import PatternedModel

    # a tension-field membrane: its wrinkled states are relaxed (tests/test_patterned_wrinkled.py)
    relaxed = PatternedModel.of(
        build_model("gent", jlim=97.0, wrinkling="tension-field"), ZonePattern.inner_circle(0.5)
    )
    assert relaxed.tension_field
    zone = PatternedModel.of(model, ZonePattern.inner_circle(0.5))
    with pytest.raises(SceneError, match="meridian of a patterned zone"):
        solve_states(zone, [1.8], 0.1, shape=True)
    # solve_states of the patterned model is the patterned shooting, derivatives included
    a = solve_states(zone, [1.8, 2.2], 0.2, TIGHT, derivatives=True)
    b = solve_patterned_states(model, ZonePattern.inner_circle(0.5), [1.8, 2.2], 0.2, TIGHT, derivatives=True)
    assert np.array_equal(a.p_hat, b.p_hat) and np.array_equal(a.derivatives.dv_dphi, b.derivatives.dv_dphi)
    assert zone.describe()["pattern"]["regions"][0] == {"outer": 0.5, "layers": 1, "electrode": True}


def test_coexist_shape_draws_patterned_zones_on_one_gas(tmp_path):
    """``coexist shape`` on three patterned zones on one gas: the ramp's state at 3.9 kV (one bulged, two not),
    each group's profile region by region, its apex the direct profile's (1e-9), the electrode edge inside."""
    import json

    from click.testing import CliRunner

    from coexist.cli.main import cli
    from coexist.shapes import patterned_profiles

    scene = tmp_path / "tri.toml"
    scene.write_text(TRICIRCLE_INNER)
    r = CliRunner().invoke(cli, ["shape", str(scene), "--voltage-kV", "3.9", "--json"])
    assert r.exit_code == 0, r.output
    (step,) = json.loads(r.stdout)["voltages"]
    assert step["configuration"] == "1 of 3 bulged" and len(step["groups"]) == 2
    from coexist.scene import parse_scene

    sc = parse_scene(TRICIRCLE_INNER)
    for g in step["groups"]:
        prof = patterned_profiles(
            sc.model(), sc.zone_pattern(), [g["pole_stretch"]], sc.phi_hat(3.9e3), zone_radius=sc.zone_radius
        )[0]
        assert g["apex_height_mm"] == pytest.approx(prof.to_dict()["apex_height_mm"], rel=1e-9)
        assert g["electrode_edge_mm"] == pytest.approx(prof.to_dict()["electrode_edge_mm"], rel=1e-9)


def test_fit_and_sweep_take_patterned_zones(tmp_path):
    """``coexist fit`` and ``coexist sweep`` on three inner-circle zones on one gas. The fitted radius, put in the
    scene, ramps to its split at the target voltage (1e-6 kV); a sweep of the electrode's radius fraction gives
    at 0.8 the split of the patterned ramp itself (3.7997343 kV, 1e-6)."""
    import json
    import re

    from click.testing import CliRunner

    from coexist.cli.main import cli

    scene = tmp_path / "tri.toml"
    scene.write_text(TRICIRCLE_INNER)
    runner = CliRunner()
    fit = runner.invoke(cli, ["fit", str(scene), "--transition-kV", "3.75", "--no-sensitivity", "--json"])
    assert fit.exit_code == 0, fit.output
    radius = json.loads(fit.stdout)["zone_radius_mm"]
    fitted = tmp_path / "fitted.toml"
    fitted.write_text(re.sub(r"zone_radius_mm = [0-9.]+", f"zone_radius_mm = {radius!r}", TRICIRCLE_INNER))
    ramp = runner.invoke(cli, ["ramp", str(fitted), "--json"])
    assert ramp.exit_code == 0, ramp.output
    ups = [t for t in json.loads(ramp.stdout)["transitions"] if t["kind"] == "spinodal" and t["direction"] == "up"]
    assert len(ups) == 1 and ups[0]["voltage_kV"] == pytest.approx(3.75, abs=1e-6)
    sweep = runner.invoke(
        cli,
        [
            "sweep",
            str(scene),
            "--vary",
            "electrodes.inner_fraction=0.7,0.8",
            "--workers",
            "1",
            "-o",
            str(tmp_path / "s.nc"),
        ],
    )
    assert sweep.exit_code == 0, sweep.output
    row = next(ln for ln in sweep.stdout.splitlines() if ln.strip().startswith("0.8"))
    assert float(row.split()[1]) == pytest.approx(3.7997343, abs=1e-6)
