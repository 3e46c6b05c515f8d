"""The ramp's table marks every jump, also one onto another branch of the same configuration (a fold inside
it), and the transitions list says so: two zones of the default membrane jump at 4.106 kV from one bulged state
to a more bulged one (the bulged zone's volume 30.7 -> 36.7 ml between the rows at 4.10 and 4.12 kV), which
printed no marker (audit of 2026-12-01)."""

import json
import re

import pytest
from click.testing import CliRunner

from coexist.cli.main import cli
from coexist.scene import builtin_scene_text


def test_a_jump_within_one_configuration_is_marked(tmp_path):
    scene = tmp_path / "zones2.toml"
    scene.write_text(builtin_scene_text("tricircle").replace("count = 3", "count = 2"))
    r = CliRunner().invoke(cli, ["ramp", str(scene)])
    assert r.exit_code == 0, r.output
    rows = {
        (m.group(1), m.group(2)): line
        for line in r.output.splitlines()
        if (m := re.match(r"\s+(4\.120|3\.940)\s+(up|down)", line))
    }
    assert "<- transition onto another branch of 1 of 2 bulged" in rows[("4.120", "up")]
    assert "<- transition onto another branch of 1 of 2 bulged" in rows[("3.940", "down")]
    assert "<-" not in rows[("4.120", "down")]
    same = [ln for ln in r.output.splitlines() if "1 of 2 bulged -> 1 of 2 bulged" in ln and "spinodal" in ln]
    assert len(same) == 2 and all("(another branch of the same configuration)" in ln for ln in same)
    up = [ln for ln in same if " up " in ln][0]
    assert re.search(r"4\.1060489\d* kV", up), up


def test_a_path_without_transitions_says_so(tmp_path):
    """A chamber closed at 10 mbar: the zones stay equal up to 5 kV; the transitions list says 'none' instead of
    an empty list (audit helper-48)."""
    scene = tmp_path / "low.toml"
    text = builtin_scene_text("tricircle")
    scene.write_text(re.sub(r"(?m)^closing_pressure_mbar = .*$", "closing_pressure_mbar = 10", text))
    r = CliRunner().invoke(cli, ["ramp", str(scene)])
    assert r.exit_code == 0, r.output
    assert "  none between 0 and 5 kV: the zones stay on one stable branch" in r.output


def test_a_closing_pressure_too_high_is_refused_before_the_ramp_starts(tmp_path):
    """Above the snap-through pressure the refusal (exit 2) comes before 'following the stable states ...'."""
    scene = tmp_path / "high.toml"
    text = builtin_scene_text("tricircle")
    scene.write_text(re.sub(r"(?m)^closing_pressure_mbar = .*$", "closing_pressure_mbar = 25", text))
    r = CliRunner().invoke(cli, ["ramp", str(scene)])
    assert r.exit_code == 2 and "snap-through" in r.output
    assert "following the stable states" not in r.output


def test_a_path_that_starts_above_zero_says_so(tmp_path):
    """Found in review: with ``start_kV = 3.95`` the table's rows start at 3.95 kV while the transitions list the
    jump at 3.900 kV (the state follows the voltage up from the closing state at 0 V); a note says so."""
    path = tmp_path / "late.toml"
    path.write_text(builtin_scene_text("tricircle").replace("start_kV = 0\n", "start_kV = 3.95\n"))
    r = CliRunner().invoke(cli, ["ramp", str(path), "--json"])
    assert r.exit_code == 0, r.output
    data = json.loads(r.stdout)
    assert data["steps"][0]["voltage_kV"] == pytest.approx(3.95)
    assert any(t["voltage_kV"] < 3.95 for t in data["transitions"])
    assert any("starts from the closing state at 0 V" in n and "3.95 kV" in n for n in data["notes"]), data["notes"]
