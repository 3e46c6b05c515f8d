"""Every committed figure is made by a command; these run those commands and assert each figure's
headline number (the commands are the ones the README lists)."""

import json

import pytest
from click.testing import CliRunner

from coexist.cli.main import cli


def run(*args):
    r = CliRunner().invoke(cli, list(args))
    assert r.exit_code == 0, r.output
    return r


@pytest.fixture(scope="module")
def ramp_run(tmp_path_factory):
    d = tmp_path_factory.mktemp("ramp")
    r = run("ramp", "-o", str(d / "ramp.png"), "--states-plot", str(d / "states.png"), "--json")
    return d, json.loads(r.stdout)


def test_ramp_figures_and_headline(ramp_run):
    """figures/tricircle_ramp.png and tricircle_states.png: one of three zones bulged between 3.8 and 4.0 kV."""
    d, data = ramp_run
    assert (d / "ramp.png").stat().st_size > 10_000 and (d / "states.png").stat().st_size > 10_000
    (jump,) = [t for t in data["transitions"] if t["kind"] == "spinodal" and t["direction"] == "up"]
    assert jump["from"] == "homogeneous" and jump["to"] == "1 of 3 bulged"
    assert 3.8 < jump["voltage_kV"] < 4.0
    at4 = [s for s in data["steps"] if s["direction"] == "up" and abs(s["voltage_kV"] - 4.0) < 1e-9][0]
    assert at4["configuration"] == "1 of 3 bulged" and at4["stable"]
    assert at4["residual_p_hat"] < 10 * data["relative_tolerance"] * 2  # converged on the exact equations
    assert len(at4["zone_volumes_ml"]) == 3 and at4["pressure_mbar"] > 0


def test_ramp_json_has_the_documented_keys(ramp_run):
    _, data = ramp_run
    step = data["steps"][0]
    assert {"voltage_kV", "pressure_mbar", "zone_volumes_ml", "configuration", "stable"} <= set(step)
    assert {"voltage_kV", "from", "to", "kind"} <= set(data["transitions"][0])
    assert "zone_radius" in data["fitted_parameters"]
    assert "gas:isothermal-ideal-gas" in data["effects"]


def test_phase_diagram_figure_and_critical_point(tmp_path):
    """figures/phase_diagram.png: critical point of Gent Jlim = 40 at Φ̂ ≈ 0.2321."""
    r = run("phase-diagram", "--phi-hat", "0.2,0.3", "--points", "6", "-o", str(tmp_path / "p.png"), "--json")
    data = json.loads(r.stdout)
    assert data["critical_point"]["phi_hat"] == pytest.approx(0.2321, abs=5e-4)
    assert (tmp_path / "p.png").stat().st_size > 10_000


def test_curves_figure(tmp_path):
    """figures/curves.png: the neo-Hookean pressure maximum p̂max = 1.8792 at Φ̂ = 0."""
    r = run("curves", "--p-hat", "1.5", "--points", "60", "-o", str(tmp_path / "c.png"), "--json")
    data = json.loads(r.stdout)
    lp = data["curves"][0]["limit_points"][0]
    assert lp["kind"] == "pressure_max" and lp["p_hat"] == pytest.approx(1.87917, abs=1e-5)


def test_coexistence_command():
    r = run("coexistence", "--json")
    data = json.loads(r.stdout)
    one = data["configurations"][0]
    assert one["bulged_zones"] == 1
    (eq,) = one["equal_free_energy"]
    assert 3.0 < eq["voltage_kV"] < 3.9 and 0 < eq["voltage_error_kV"] < 1e-6
    assert eq["bulged_volume_ml"] > eq["unbulged_volume_ml"]
    (rng,) = one["stable_ranges"]
    assert rng["from_event"] == "fold" and rng["to_event"] == "range_end"


def test_ramp_bad_scene_is_exit_2(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text("[membrane]\nthickness = 0.5\n")
    r = CliRunner().invoke(cli, ["ramp", str(bad)])
    assert r.exit_code == 2 and "thickness" in r.output


def test_ramp_scene_without_voltage_is_exit_2():
    r = CliRunner().invoke(cli, ["ramp", "two-balloons"])
    assert r.exit_code == 2 and "[voltage]" in r.output


def test_coexistence_without_voltage_lists_the_equilibria():
    """two-balloons (no voltage): the closed gas at 30 mbar holds both balloons equal and stable."""
    r = run("coexistence", "two-balloons", "--json")
    data = json.loads(r.stdout)
    (eq,) = data["equilibria_at_0V"]
    assert eq["configuration"] == "homogeneous" and eq["stable"]
    assert eq["pressure_mbar"] == pytest.approx(30.0, rel=1e-6)
    assert eq["zone_volumes_ml"][0] == pytest.approx(eq["zone_volumes_ml"][1], rel=1e-12)


def test_shapes_figure_and_headline(ramp_run, tmp_path):
    """figures/tricircle_shapes.png (`coexist shape tricircle --voltage-kV 0,3.8,4.0 -o ...`): at 4.0 kV the
    bulged zone's apex is 39.77 mm high (two unbulged at 12.76 mm), the same number as the library's state of
    the default ramp (its own voltage steps) shot again here."""
    from coexist.scene import load_scene
    from coexist.shooting import solve_states

    png = tmp_path / "shapes.png"
    r = run("shape", "tricircle", "--voltage-kV", "0,3.8,4.0", "--points", "41", "-o", str(png), "--json")
    assert png.stat().st_size > 10_000
    at4 = json.loads(r.stdout)["voltages"][2]
    assert at4["configuration"] == "1 of 3 bulged"
    low, high = at4["groups"]
    assert high["apex_height_mm"] == pytest.approx(39.767, abs=1e-3) and low["apex_height_mm"] == pytest.approx(
        12.759, abs=1e-3
    )
    # independently: the ramp's state at 4.0 kV (a different path: 0.02 kV steps), shot with solve_states
    _, data = ramp_run
    step = [s for s in data["steps"] if s["direction"] == "up" and abs(s["voltage_kV"] - 4.0) < 1e-9][0]
    sc = load_scene("tricircle")
    lam = max(step["pole_stretches"])
    st = solve_states(sc.model(), [lam], float(sc.phi_hat(4000.0)))
    assert high["apex_height_mm"] == pytest.approx(st.apex_height[0] * sc.zone_radius * 1e3, rel=1e-8)
