"""Patterned zones in scenes and on the command line (issue 13, step 3).

``[electrodes] pattern / inner_fraction / outer_fraction`` and ``[layers] passive`` are read, checked (one-line
errors naming the field, exit 2 from the CLI), turned into the :class:`~coexist.patterned.ZonePattern` of the
library, listed among the effects only when a scene names them; scenes without them are unchanged. ``coexist
curves`` computes a patterned zone's p̂–V̂ curves with :func:`~coexist.patterned.patterned_pressure_volume_curve`
(the same numbers as the direct call); every N-zone command takes patterned zones
(tests/test_patterned_derivatives.py).
"""

import json

import numpy as np
import pytest
from click.testing import CliRunner
from conftest import one_line_error

from coexist import patterned
from coexist.errors import SceneError
from coexist.model import build_model
from coexist.patterned import ZonePattern, patterned_pressure_volume_curve
from coexist.scene import builtin_scene_text, builtin_scenes, load_scene, parse_scene
from coexist.scene_format import MAX_LAYERS
from coexist.settings import SolverSettings

#: a valid one-zone scene without pattern: material, geometry, a controlled pressure
BASE = """
[membrane]
material = "gent"
jlim = 97
shear_modulus_kPa = 45
relative_permittivity = 4.7
thickness_mm = 0.5
zone_radius_mm = 32.5
[zones]
count = 1
pressure_mbar = 10
"""
INNER = BASE + '[electrodes]\npattern = "inner-circle"\ninner_fraction = 0.5\n[layers]\npassive = 2\n'
RING = BASE + '[electrodes]\npattern = "ring"\ninner_fraction = 0.3\nouter_fraction = 0.7\n[layers]\npassive = 2\n'


def invoke(args, stdin=None):
    from coexist.cli.main import cli

    return CliRunner().invoke(cli, args, input=stdin)


# --- parsing ---------------------------------------------------------------------------------------------
def test_inner_circle_and_ring_scenes_give_their_zone_patterns():
    inner = parse_scene(INNER)
    assert (inner.electrode_pattern, inner.inner_fraction, inner.outer_fraction, inner.passive_layers) == (
        "inner-circle",
        0.5,
        None,
        2,
    )
    assert inner.patterned and inner.zone_pattern() == ZonePattern.inner_circle(0.5, passive_layers=2)
    assert inner.zone_pattern().regions == (
        patterned.Region(0.5, 1, True),
        patterned.Region(1.0, 2, False),
    )
    ring = parse_scene(RING)
    assert ring.zone_pattern() == ZonePattern.ring(0.3, 0.7, passive_layers=2)
    assert [r.electrode for r in ring.zone_pattern().regions] == [False, True, False]
    # a ring reaching the clamp: two regions, the outer one the electrode
    clamp = parse_scene(RING.replace("outer_fraction = 0.7", "outer_fraction = 1"))
    assert clamp.zone_pattern().regions == (patterned.Region(0.3, 2, False), patterned.Region(1.0, 1, True))
    # one passive layer is the default of a present pattern (and not a "defaulted" standard value)
    single = parse_scene(INNER.replace("[layers]\npassive = 2\n", ""))
    assert single.passive_layers == 1 and single.zone_pattern().regions[1].layers == 1
    assert "[layers].passive" not in single.defaulted


def test_effects_values_and_json_name_the_pattern_only_when_the_scene_does():
    inner = parse_scene(INNER)
    effects = inner.effects()
    assert "electrodes:inner-circle" in effects and "layers:2" in effects
    assert effects.index("electrodes:inner-circle") < effects.index("layers:2") < effects.index("pressure-control")
    rows = {k: (v, src) for k, v, src in inner.values()}
    assert rows["[electrodes].pattern"] == ("inner-circle", "file")
    assert rows["[electrodes].inner_fraction"] == ("0.5", "file")
    assert rows["[layers].passive"] == ("2", "file") and "[electrodes].outer_fraction" not in rows
    data = json.loads(json.dumps(inner.to_dict(), allow_nan=False))
    assert data["electrodes"] == {"pattern": "inner-circle", "inner_fraction": 0.5, "outer_fraction": None}
    assert data["layers"] == {"passive": 2}
    # one passive layer is not an effect
    assert not any(e.startswith("layers:") for e in parse_scene(INNER.replace("passive = 2", "passive = 1")).effects())
    # a scene that names the full pattern is the scene without it
    named_full = parse_scene(BASE + '[electrodes]\npattern = "full"\n')
    plain = parse_scene(BASE)
    assert named_full == plain and named_full.effects() == plain.effects() and named_full.values() == plain.values()


@pytest.mark.parametrize("name", ["tricircle", "single-zone", "two-balloons"])
def test_existing_scenes_are_unchanged(name):
    scene = load_scene(name)
    assert not scene.patterned and scene.zone_pattern() == ZonePattern.full()
    assert (scene.electrode_pattern, scene.inner_fraction, scene.outer_fraction, scene.passive_layers) == (
        "full",
        None,
        None,
        1,
    )
    assert not any(e.startswith(("electrodes:", "layers:")) for e in scene.effects())
    assert not any(k.startswith(("[electrodes]", "[layers]")) for k, _, _ in scene.values())
    assert not any(k.startswith(("[electrodes]", "[layers]")) for k in scene.defaulted)
    scene.require_uniform("this test")  # no error


def test_the_scene_format_and_the_library_agree_on_the_layer_limit():
    assert MAX_LAYERS == patterned.MAX_LAYERS
    assert parse_scene(INNER.replace("passive = 2", f"passive = {MAX_LAYERS}")).passive_layers == MAX_LAYERS


# --- every validation error: one line naming the field, exit 2 from the CLI -----------------------------------
BAD = [
    # (replace in INNER or a whole text, the field, a fragment of the message)
    (INNER.replace('"inner-circle"', '"inner-circel"'), "[electrodes].pattern", "did you mean 'inner-circle'"),
    (INNER.replace('"inner-circle"', '"Inner-Circle"'), "[electrodes].pattern", "did you mean 'inner-circle'"),
    (INNER.replace('"inner-circle"', '"rings"'), "[electrodes].pattern", "did you mean 'ring'"),
    (INNER.replace('"inner-circle"', "3"), "[electrodes].pattern", "expected a string"),
    (INNER.replace("inner_fraction = 0.5", "inner_fraction = 0"), "[electrodes].inner_fraction", "between 0 and 1"),
    (INNER.replace("inner_fraction = 0.5", "inner_fraction = 1"), "[electrodes].inner_fraction", "between 0 and 1"),
    (INNER.replace("inner_fraction = 0.5", "inner_fraction = 1.5"), "[electrodes].inner_fraction", "between 0 and 1"),
    (INNER.replace("inner_fraction = 0.5", "inner_fraction = -0.2"), "[electrodes].inner_fraction", "between 0 and 1"),
    (INNER.replace("inner_fraction = 0.5", 'inner_fraction = "0.5"'), "[electrodes].inner_fraction", "a number"),
    (INNER.replace("inner_fraction = 0.5", "inner_fraction = nan"), "[electrodes].inner_fraction", "finite"),
    (INNER.replace("inner_fraction = 0.5", "inner_fracton = 0.5"), "[electrodes].inner_fracton", "inner_fraction"),
    (INNER.replace("inner_fraction = 0.5", "inner_fraction_mm = 16"), "[electrodes].inner_fraction_mm", "unknown key"),
    (INNER.replace("inner_fraction = 0.5\n", ""), "[electrodes].inner_fraction", "missing"),
    (
        INNER.replace("inner_fraction = 0.5", "inner_fraction = 0.5\nouter_fraction = 0.8"),
        "[electrodes].outer_fraction",
        'only the "ring" pattern takes',
    ),
    (RING.replace("outer_fraction = 0.7", "outer_fraction = 0.3"), "[electrodes].outer_fraction", "outside its inner"),
    (RING.replace("outer_fraction = 0.7", "outer_fraction = 0.2"), "[electrodes].outer_fraction", "outside its inner"),
    (RING.replace("outer_fraction = 0.7", "outer_fraction = 1.2"), "[electrodes].outer_fraction", "at most 1"),
    (RING.replace("outer_fraction = 0.7\n", ""), "[electrodes].outer_fraction", "missing"),
    (RING.replace("inner_fraction = 0.3\n", ""), "[electrodes].inner_fraction", "missing"),
    (BASE + "[electrodes]\ninner_fraction = 0.5\n", "[electrodes].inner_fraction", "no pattern is given"),
    (BASE + '[electrodes]\npattern = "full"\ninner_fraction = 0.5\n', "[electrodes].inner_fraction", "only the"),
    (BASE + "[electrodes]\n", "[electrodes].pattern", "missing"),
    ("electrodes = 3\n" + BASE, "[electrodes]", "must be a table"),
    (INNER.replace("passive = 2", "passive = 0"), "[layers].passive", "from 1 to 100"),
    (INNER.replace("passive = 2", "passive = 101"), "[layers].passive", "from 1 to 100"),
    (INNER.replace("passive = 2", "passive = 2.5"), "[layers].passive", "whole number"),
    (INNER.replace("passive = 2", "passive = true"), "[layers].passive", "whole number"),
    (INNER.replace("passive = 2", "pasive = 2"), "[layers].pasive", "did you mean 'passive'"),
    (INNER.replace("passive = 2", ""), "[layers].passive", "missing"),
    (BASE + "[layers]\npassive = 2\n", "[layers].passive", "no region without electrode"),
    (BASE + '[electrodes]\npattern = "full"\n[layers]\npassive = 3\n', "[layers].passive", "no region without"),
    (BASE + "[electrode]\npattern = 'ring'\n", "[electrode]", "did you mean '[electrodes]'"),
]


@pytest.mark.parametrize("text, field, fragment", BAD, ids=[f"{f}:{m}"[:60] for _, f, m in BAD])
def test_every_bad_pattern_field_is_a_one_line_error_naming_it(text, field, fragment):
    with pytest.raises(SceneError) as info:
        parse_scene(text)
    assert info.value.field == field, str(info.value)
    assert fragment in str(info.value) and "\n" not in str(info.value)
    one_line_error(invoke(["check", "-", "--no-solve"], stdin=text), field, fragment)


# --- coexist check and coexist scenes -----------------------------------------------------------------------
def test_the_inner_circle_scene_is_built_in_and_checked_with_the_patterned_zone():
    assert "inner-circle" in builtin_scenes()
    listed = invoke(["scenes"])
    assert listed.exit_code == 0 and any(ln.startswith("inner-circle ") for ln in listed.output.splitlines())
    scene = load_scene("inner-circle")
    assert scene.zone_radius == pytest.approx(32.5e-3, rel=1e-15) and scene.zone_count == 1
    assert scene.zone_pattern() == ZonePattern.inner_circle(0.5, passive_layers=2)
    assert invoke(["scenes", "show", "inner-circle"]).output == builtin_scene_text("inner-circle")
    assert "ILLUSTRATIVE" in builtin_scene_text("inner-circle")
    result = invoke(["check", "inner-circle", "--json"])
    assert result.exit_code == 0, result.output
    data = json.loads(result.stdout)
    assert data["effects"][2:4] == ["electrodes:inner-circle", "layers:2"]
    assert "ramp_cost" not in data and "coexist curves" in result.stderr
    # the check's p̂max is the patterned zone's: the uniform Gent zone holds only 1.9727 (13.66 mbar) and
    # would refuse the scene's 16 mbar (p̂ = 2.311)
    base = scene.model()
    from coexist.effects import NoElectrostatics
    from coexist.model import MembraneModel

    passive = MembraneModel(base.elasticity, NoElectrostatics(), base.prestretch)
    direct = patterned_pressure_volume_curve(passive, scene.zone_pattern(), 0.0, np.linspace(1.01, 6.5, 120))
    p_max = [lp.p_hat for lp in direct.limit_points if lp.kind == "pressure_max"][0]
    assert data["snap_through_pressure_hat"] == pytest.approx(p_max, rel=1e-9, abs=0)
    assert data["snap_through_pressure_hat"] == pytest.approx(2.37198884, abs=1e-7)
    assert data["dimensionless_groups"]["closing_pressure_hat"] < p_max


def test_a_closing_pressure_above_the_patterned_snap_through_is_refused():
    text = builtin_scene_text("inner-circle").replace("closing_pressure_mbar = 16", "closing_pressure_mbar = 17")
    one_line_error(invoke(["check", "-"], stdin=text), "[chamber].closing_pressure_mbar", "p̂max = 2.372")


# --- coexist curves ---------------------------------------------------------------------------------------
def _pv(result):
    assert result.exit_code == 0, result.output
    data = json.loads(result.stdout)
    return data, [c for c in data["curves"] if c["family"] == "pressure_volume"]


def test_curves_of_the_inner_circle_scene_are_the_patterned_library_curves():
    data, curves = _pv(invoke(["curves", "--scene", "inner-circle", "--phi-hat", "0.1", "--json"]))
    # the default Φ̂–Q̂ curves too, as for a uniform zone (p̂ 1.2, 1.5, 1.7)
    assert [c["family"] for c in data["curves"]] == ["pressure_volume"] + ["voltage_charge"] * 3
    assert data["model"]["pattern"]["regions"] == [
        {"outer": 0.5, "layers": 1, "electrode": True},
        {"outer": 1.0, "layers": 2, "electrode": False},
    ]
    cli_max = [lp["p_hat"] for lp in curves[0]["limit_points"] if lp["kind"] == "pressure_max"]
    model = build_model("gent", 97, voltage=True)
    direct = patterned_pressure_volume_curve(
        model, ZonePattern.inner_circle(0.5, passive_layers=2), 0.1, np.linspace(1.01, 4, 200), SolverSettings()
    )
    direct_max = [lp.p_hat for lp in direct.limit_points if lp.kind == "pressure_max"]
    assert len(cli_max) == len(direct_max) == 1
    assert cli_max[0] == pytest.approx(direct_max[0], rel=1e-10, abs=0)
    np.testing.assert_allclose(curves[0]["v_hat"], direct.states.v_hat, rtol=1e-10, atol=0)
    # measured 2.2665279776 (tests/test_patterned.py checks the patterned shooting itself); not the uniform
    # zone's 1.8976 at this voltage
    assert cli_max[0] == pytest.approx(2.2665279776, abs=1e-8)


def test_the_pattern_options_give_the_scenes_curves_and_override_it():
    options = ["--material", "gent", "--jlim", "97", "--phi-hat", "0.1", "--points", "60", "--json"]
    scene_run = _pv(invoke(["curves", "--scene", "inner-circle", *options[4:]]))[1]
    option_run = _pv(
        invoke(["curves", *options, "--pattern", "inner-circle", "--inner-fraction", "0.5", "--passive-layers", "2"])
    )[1]
    assert scene_run[0]["p_hat"] == option_run[0]["p_hat"] and scene_run[0]["limit_points"]
    # one passive layer instead of the scene's two: a softer annulus, a lower pressure maximum
    one_layer = _pv(invoke(["curves", "--scene", "inner-circle", "--passive-layers", "1", *options[4:]]))[1]
    p2 = max(lp["p_hat"] for lp in scene_run[0]["limit_points"] if lp["kind"] == "pressure_max")
    p1 = max(lp["p_hat"] for lp in one_layer[0]["limit_points"] if lp["kind"] == "pressure_max")
    assert p1 < p2 - 0.2, (p1, p2)


def test_a_full_pattern_leaves_the_uniform_curves_unchanged():
    args = ["curves", "--material", "gent", "--jlim", "97", "--phi-hat", "0.1", "--p-hat", "1.5", "--points", "40"]
    plain = invoke([*args, "--json"])
    full = invoke([*args, "--pattern", "full", "--json"])
    assert plain.exit_code == full.exit_code == 0
    assert json.loads(plain.stdout) == json.loads(full.stdout)
    assert "pattern" not in json.loads(plain.stdout)["model"]


def test_patterned_curves_go_to_csv_and_a_figure(tmp_path):
    csv_path, png = tmp_path / "c.csv", tmp_path / "c.png"
    args = ["curves", "--scene", "inner-circle", "--phi-hat", "0.1", "--points", "40", "--csv", str(csv_path)]
    result = invoke([*args, "-o", str(png)])
    assert result.exit_code == 0, result.output
    rows = csv_path.read_text().splitlines()
    assert rows[0].startswith("family,fixed_name,fixed_value") and len(rows) > 10
    # both families by default, as for a uniform zone
    assert {r.split(",")[0] for r in rows[1:]} == {"pressure_volume", "voltage_charge"}
    assert png.stat().st_size > 1000


@pytest.mark.parametrize(
    "args, fragments",
    [
        (["--pattern", "inner-circle"], ["--inner-fraction", "missing"]),
        (["--pattern", "inner-circle", "--inner-fraction", "1.5"], ["--inner-fraction", "between 0 and 1"]),
        (["--pattern", "inner-circle", "--inner-fraction", "1"], ["--inner-fraction", 'is the "full" pattern']),
        (["--pattern", "ring", "--inner-fraction", "0.3"], ["--outer-fraction", "missing"]),
        (["--pattern", "ring", "--inner-fraction", "0.6", "--outer-fraction", "0.4"], ["--outer-fraction", "outside"]),
        (["--inner-fraction", "0.5"], ["--inner-fraction", 'the pattern is "full"']),
        (["--pattern", "inner-circle", "--inner-fraction", "0.5", "--outer-fraction", "0.7"], ["--outer-fraction"]),
        (["--passive-layers", "2"], ["--passive-layers", "no region without electrode"]),
        (["--pattern", "inner-circle", "--inner-fraction", "0.5", "--passive-layers", "0"], ["--passive-layers"]),
        (["--scene", "inner-circle", "--pattern", "ring", "--outer-fraction", "0.4"], ["--outer-fraction", "0.5"]),
        (["--pattern", "circle"], ["--pattern", "circle"]),
    ],
)
def test_bad_pattern_options_are_one_line_errors(args, fragments):
    one_line_error(invoke(["curves", *args, "--phi-hat", "0.1", "--points", "10"]), *fragments)


def test_a_pattern_field_swept_on_a_uniform_scene_and_a_model_without_the_pattern_are_refused():
    """Every N-zone command takes patterned zones (tests/test_patterned_derivatives.py); what stays refused: a swept
    pattern key on a scene without a pattern (its corners are no scenes, naming the field), and a Simulation
    given a model that does not carry the scene's pattern."""
    one_line_error(
        invoke(["sweep", "tricircle", "--vary", "electrodes.inner_fraction=0.3,0.5"]),
        "--vary",
        "inner_fraction",
    )
    from coexist.simulation import Simulation

    scene = load_scene("inner-circle")
    with pytest.raises(SceneError, match="does not carry the scene's pattern") as info:
        Simulation.from_scene(scene, model=scene.model())
    assert info.value.field == "[electrodes].pattern"
