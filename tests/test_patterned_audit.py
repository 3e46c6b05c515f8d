"""Patterned zones next to the built-in ones (third audit, helper-35): a ring short of the clamp and an inner circle
on a prestretched membrane. The first crashed inside the interface-scale search (``math.log`` of a clamp met at the
pole); the second refused every closing pressure ("below the smallest computed state (p̂ = nan)") because the
state just above the prestretch wrinkles there."""

import json

import pytest
from click.testing import CliRunner

from coexist.cli.main import cli
from coexist.scene import builtin_scene_text


def test_a_ring_short_of_the_clamp_has_its_zero_voltage_curve():
    """At zero voltage a one-layer ring zone is the uniform membrane: its pressure maximum is the neo-Hookean
    one, 1.8791734687682 (an independent scipy shooting, second audit)."""
    args = ["curves", "--pattern", "ring", "--inner-fraction", "0.5", "--outer-fraction", "0.9"]
    r = CliRunner().invoke(cli, [*args, "--phi-hat", "0", "--p-hat", "none", "--json"])
    assert r.exit_code == 0, r.output
    (curve,) = json.loads(r.stdout)["curves"]
    assert len(curve["pole_stretch"]) == 200
    (top,) = [lp for lp in curve["limit_points"] if lp["kind"] == "pressure_max"]
    assert top["p_hat"] == pytest.approx(1.8791734687682, rel=1e-9)


def test_an_inner_circle_on_a_prestretched_membrane_ramps(tmp_path):
    text = builtin_scene_text("inner-circle").replace("prestretch = 1.0\n", "prestretch = 1.5\n")
    assert "prestretch = 1.5" in text
    (tmp_path / "pre.toml").write_text(text)
    assert CliRunner().invoke(cli, ["check", str(tmp_path / "pre.toml")]).exit_code == 0
    r = CliRunner().invoke(cli, ["ramp", str(tmp_path / "pre.toml"), "--json"])
    assert r.exit_code == 0, r.output
    kinds = [(t["kind"], round(t["voltage_kV"], 4)) for t in json.loads(r.stdout)["transitions"]]
    assert kinds == [("no_stable_state", 3.9315), ("re_entry", 3.9315)], kinds


def test_coexistence_of_one_zone_says_where_its_bistability_is():
    r = CliRunner().invoke(cli, ["coexistence", "inner-circle"])
    assert r.exit_code == 0, r.output
    assert "one zone has no configurations" in r.stderr and "coexist ramp" in r.stderr
