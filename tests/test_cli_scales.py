"""The text output prints every physical number with meaningful digits at any scale (review, helper-101).

The tables printed fixed decimals in kV, mbar and ml (``{:.3f}`` voltages, ``{:.4f}`` pressures): a micro-actuator
(a 50 µm zone, 1 µm thick, 10 Pa, ramped to 0.15 V) printed every row as ``0.000 up 0.0038 0.000 0.000 0.000``, and
a 1 m balloon (10 mm, 1 MPa, 470 kV, a 30 m³ chamber) volumes of 2290722.698 ml that pushed the columns apart. Both
scenes here are the tricircle's physics scaled (the same p̂ closing, Φ̂ range, V̂ chamber and p̂ atmosphere), on a
coarse voltage step (20 steps up). Every number the text prints is compared with the JSON's (full precision).
"""

import json
import math
import re

import pytest
from click.testing import CliRunner

from coexist.cli.main import cli

_MEMBRANE = """
[membrane]
material = "gent"
jlim = 97
relative_permittivity = 4.7
wrinkling = "tension-field"
{membrane}
[zones]
count = 3
[chamber]
{chamber}
[voltage]
{voltage}
"""

SCENES = {
    # A = 50 µm, H = 1 µm, μ = 10 Pa: pressure scale μH/A = 0.2 Pa, voltage scale 0.49 V, volumes of 1e-7 ml
    "micro": _MEMBRANE.format(
        membrane="shear_modulus_Pa = 10\nthickness_um = 1\nzone_radius_um = 50",
        chamber="volume_m3 = 3.8176e-12\nclosing_pressure_Pa = 0.38074\natmospheric_pressure_Pa = 19.289",
        voltage="stop_V = 0.15\nstep_V = 0.0075",
    ),
    # A = 1 m, H = 10 mm, μ = 1 MPa: pressure scale 1e4 Pa, voltage scale 1550 kV, volumes of 1e6 ml
    "macro": _MEMBRANE.format(
        membrane="shear_modulus_MPa = 1\nthickness_mm = 10\nzone_radius_m = 1",
        chamber="volume_m3 = 30.54\nclosing_pressure_Pa = 19037\natmospheric_pressure_kPa = 964.46",
        voltage="stop_kV = 470\nstep_kV = 23.5",
    ),
}


def run(*args):
    r = CliRunner().invoke(cli, [str(a) for a in args])
    assert r.exit_code == 0, r.output
    return r.stdout


@pytest.fixture(scope="module")
def scenes(tmp_path_factory):
    folder = tmp_path_factory.mktemp("scales")
    paths = {}
    for name, text in SCENES.items():
        paths[name] = folder / f"{name}.toml"
        paths[name].write_text(f'name = "{name}"\n' + text)
    return paths


def significant_digits(text: str) -> int:
    """The significant digits a printed number shows (``0.00380738`` -> 6, ``2.8634e-07`` -> 5)."""
    mantissa = text.lower().split("e")[0].lstrip("-").replace(".", "")
    return len(mantissa.lstrip("0"))


@pytest.mark.parametrize("name", ["micro", "macro"])
def test_ramp_table_prints_distinct_voltages_and_the_numbers_of_any_scale(scenes, name):
    text = run("ramp", scenes[name]).splitlines()
    data = json.loads(run("ramp", scenes[name], "--json"))
    steps = data["steps"]
    head, rows = text[0], text[1 : 1 + len(steps)]
    assert len(steps) == 41 and all(re.match(r"\s*\S+\s+(up|down)\s", row) for row in rows)
    # every row its own voltage (before: all 0.000 kV for the micro scene)
    shown = [tuple(row.split()[:2]) for row in rows]
    assert len(set(shown)) == len(rows), shown
    for row, step in zip(rows, steps):
        kv, direction, pressure, *rest = row.split()
        assert direction == step["direction"]
        assert float(kv) == pytest.approx(step["voltage_kV"], rel=1e-9)
        # the columns line up whatever the numbers' lengths (before: 2290722.698 ml pushed them apart)
        assert row.index(f" {step['configuration']} ") == head.index(" configuration ")
        if step["pressure_mbar"] is None:
            assert pressure == "-" and rest[0] == "-"
            continue
        # six significant figures of the largest pressure, five of the largest volume (before: 0.0038, 0.000)
        assert float(pressure) == pytest.approx(step["pressure_mbar"], rel=2e-5)
        assert significant_digits(pressure) >= 5
        volumes = rest[:3]
        assert [float(v) for v in volumes] == pytest.approx(step["zone_volumes_ml"], rel=1e-4)
        assert all(significant_digits(v) >= 5 for v in volumes), volumes
    # a transition voltage with every decimal its measured error supports (before: at most 10, 0.0001162765 ± 1e-13)
    for t in data["transitions"]:
        line = next(ln for ln in text if re.match(rf"\s+{t['kind']}\s+{t['direction']}\s", ln))
        kv, err = re.search(r"(\S+) kV ± (\S+)", line).groups()
        assert float(err) == pytest.approx(t["voltage_error_kV"], rel=0.5)
        assert len(kv.split(".")[1]) >= math.ceil(-math.log10(t["voltage_error_kV"]))
        assert float(kv) == pytest.approx(t["voltage_kV"], abs=t["voltage_error_kV"])


def test_coexistence_prints_the_coexisting_state_of_a_micro_scene(scenes):
    text = run("coexistence", scenes["micro"])
    (equal,) = json.loads(run("coexistence", scenes["micro"], "--json"))["configurations"][0]["equal_free_energy"]
    found = re.search(r"at (\S+) kV ± \S+: (\S+) mbar, unbulged (\S+) ml \(λ0 \S+\), bulged (\S+) ml", text).groups()
    kv, pressure, unbulged, bulged = (float(x) for x in found)
    assert kv == pytest.approx(equal["voltage_kV"], abs=equal["voltage_error_kV"])
    # before: 0.0030 mbar, 0.0000 ml and 0.0000 ml
    assert pressure == pytest.approx(equal["pressure_mbar"], rel=1e-5)
    assert unbulged == pytest.approx(equal["unbulged_volume_ml"], rel=1e-5)
    assert bulged == pytest.approx(equal["bulged_volume_ml"], rel=1e-5)


def test_shape_table_of_a_micro_scene(scenes):
    args = ("shape", scenes["micro"], "--voltage-kV", "0,0.0001,0.00012", "--points", "5")
    text = run(*args).splitlines()
    data = json.loads(run(*args, "--json"))
    groups = [g for e in data["voltages"] for g in e["groups"] for _ in range(g["zones"])]
    rows = text[1 : 1 + len(groups)]
    assert [row.split()[0] for row in rows] == ["0.00000"] * 3 + ["0.00010"] * 3 + ["0.00012"] * 3
    for row, g in zip(rows, groups):
        _, _, _, height, curvature, roc, r_edge, *_ = row.replace("(", " ").replace(",", " ").split()
        # before: 0.051357 mm, radius of curvature 0.0535 mm, edge (0.0500, 0.0000)
        assert float(height) == pytest.approx(g["apex_height_mm"], rel=1e-7)
        assert float(curvature) == pytest.approx(g["apex_curvature_per_m"], rel=1e-7)
        assert float(roc) == pytest.approx(g["radius_of_curvature_mm"], rel=1e-5)
        assert significant_digits(roc) >= 6 and significant_digits(r_edge) >= 6


def test_sweep_table_of_a_micro_scene(scenes):
    text = run("sweep", scenes["micro"], "--vary", "chamber.closing_pressure_Pa=0.38,0.39", "--workers", "1")
    rows = [ln.split() for ln in text.splitlines()[1:] if ln.split()[-1] == "bulges"]
    assert len(rows) == 2
    for _, up, down, hyst, jump_up, jump_down, _ in rows:
        # before: 0.000118 0.000107 0.000011 (three and two significant figures)
        assert all(significant_digits(x) >= 6 for x in (up, down, jump_up, jump_down)), (up, down)
        assert float(up) - float(down) == pytest.approx(float(hyst), abs=2e-10)
        assert 0 < float(down) < float(up) < 0.00015


def test_fit_sensitivity_table_of_a_micro_scene(scenes):
    text = run("fit", scenes["micro"], "--transition-kV", "0.000116")
    rows = [ln.split() for ln in text.splitlines() if ln.startswith(("baseline", "zone_radius_mm", "shear_modulus"))]
    assert len(rows) == 5
    spinodal = [row[-2] for row in rows]
    # before: 0.0001 in every row
    assert len(set(spinodal)) == 5 and all(significant_digits(x) >= 5 for x in spinodal), spinodal
    assert float(spinodal[0]) == pytest.approx(0.000116, rel=1e-4)


def test_the_default_scene_table_is_unchanged():
    text = run("ramp", "--every", "10")
    assert text.splitlines()[0] == (
        "voltage_kV  dir pressure_mbar  zone_volumes_ml              configuration      stable"
    )
    for line in (
        "     0.000   up       20.0000  22.502 22.502 22.502         homogeneous        yes",
        "     3.920   up       11.6676  11.259 11.259 47.976         1 of 3 bulged      yes  <- transition",
        "     3.540 down       17.3896  22.812 22.812 22.812         homogeneous        yes  <- transition",
        "  spinodal           up     3.900030858 kV ± 5e-09     homogeneous -> 1 of 3 bulged  [split]",
    ):
        assert line in text.splitlines()


def test_the_helpers():
    from coexist.cli.common import column_format, format_voltage, significant, voltage_decimals

    assert format_voltage(3.900030858, 5e-9) == "3.900030858 kV ± 5e-09"  # as it always was
    assert format_voltage(1.162764548e-4, 1e-13) == "0.0001162764548 kV ± 1e-13"  # before: 10 decimals at most
    assert format_voltage(0.00015, 0.0) == "0.00015 kV ± 0e+00"  # an exact end (before: 0.000)
    assert format_voltage(5.0, 0.0) == "5.000 kV ± 0e+00"
    assert significant(20.0) == "20.0000" and significant(123456.7) == "123457" and significant(0.0) == "0.00000"
    assert column_format([None, 0.0], 6)(0.0) == "0.00000"  # no value to scale by: as a value of order 1
    assert column_format([12345678.0], 6)(12345678.0) == "1.23457e+07"
    assert voltage_decimals([]) == 3 and voltage_decimals([0.0, 400.0, 470.0]) == 3
    assert voltage_decimals([0, 1 / 3, 2 / 3]) == 3  # never exact: as many as tell them apart, at least 3
