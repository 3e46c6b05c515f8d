"""The sweep and the phase diagram agree with the scene rules and name fields as a scene file does: jlim only with
Gent (as `coexist check`), pressure fields in their scene-file spelling, and the phase diagram says which of a
scene's fields it takes (taut zones: not the scene's wrinkling)."""

import pytest
from click.testing import CliRunner

from coexist import sweep as sw
from coexist.cli.main import cli
from coexist.errors import SceneError
from coexist.scene import builtin_scene_text, parse_scene


def run(*args):
    return CliRunner().invoke(cli, list(args))


def test_check_refuses_jlim_without_gent():
    """The scene rule the sweep follows: a scene file with a neo-Hookean membrane and a jlim is refused."""
    text = builtin_scene_text("tricircle").replace('material = "gent"', 'material = "neo-hookean"')
    with pytest.raises(SceneError, match="only the gent material takes jlim"):
        parse_scene(text)


def test_sweeping_jlim_with_neo_hookean_is_refused_before_any_work():
    """membrane.material=gent,neo-hookean with membrane.jlim swept: the neo-Hookean points would carry a jlim,
    which no scene may: refused by make_spec (naming --vary and both keys), exit 2 with one line."""
    with pytest.raises(SceneError, match=r"membrane\.jlim with membrane\.material=neo-hookean") as info:
        sw.make_spec("tricircle", ["membrane.material=gent,neo-hookean", "membrane.jlim=60,97"])
    assert info.value.field == "--vary"
    r = run("sweep", "tricircle", "--vary", "membrane.material=gent,neo-hookean", "--vary", "membrane.jlim=60,97")
    assert r.exit_code == 2
    error_lines = [line for line in r.output.splitlines() if line.startswith("Error:")]
    assert len(error_lines) == 1 and "--vary" in error_lines[0] and "only the gent material takes jlim" in r.output
    assert "Traceback" not in r.output


def test_a_neo_hookean_point_drops_jlim_and_says_so():
    """The documented rule (vary_document): a neo-Hookean point drops the scene's jlim = 97; the sweep notes it
    (spec_notes, printed by the command) and the point's scene is the neo-Hookean one without jlim."""
    spec = sw.make_spec("tricircle", ["membrane.material=gent,neo-hookean"])
    notes = sw.spec_notes(spec)
    assert len(notes) == 1 and "jlim = 97 is dropped" in notes[0] and "neo-hookean" in notes[0]
    gent, neo = spec.scene_at(0), spec.scene_at(1)
    assert (gent.material, gent.jlim) == ("gent", 97.0)
    assert (neo.material, neo.jlim) == ("neo-hookean", None)
    assert sw.spec_notes(sw.make_spec("tricircle", ["membrane.zone_radius_mm=21,22"])) == []
    r = run(
        "sweep", "tricircle", "--vary", "membrane.material=gent,neo-hookean", "--vary", "voltage.stop_kV=1",
        "--workers", "1",
    )  # fmt: skip
    assert r.exit_code == 0, r.output
    assert "note: membrane.material=neo-hookean: the scene's jlim = 97 is dropped" in r.output


def test_no_start_names_the_scene_file_key():
    """inner-circle with inner_fraction 0.6: the zones cannot hold its 16 mbar; the reason names the key as a
    scene file and --vary spell it, [chamber].closing_pressure_mbar (it named the sweep document's
    closing_pressure_Pa)."""
    spec = sw.make_spec("inner-circle", ["electrodes.inner_fraction=0.6"])
    rec = sw.evaluate_point(spec, 0)
    assert rec["status"] == "no_start"
    assert rec["reason"].startswith("[chamber].closing_pressure_mbar: the zones cannot hold 16 mbar")
    assert "_Pa" not in rec["reason"]


def test_controlled_pressure_field_spelling():
    """The same for a controlled pressure ([zones].pressure_mbar), and a swept pressure keeps its key's spelling."""
    text = builtin_scene_text("tricircle")
    start, end = text.index("[chamber]"), text.index("[voltage]")
    text = text[:start] + text[end:]
    text = text.replace("count = 3", "count = 3\npressure_mbar = 19")
    spec = sw.make_spec(parse_scene(text), ["membrane.zone_radius_mm=21,22"])
    assert spec.scene_at(0).controlled_pressure_field == "[zones].pressure_mbar"
    swept = sw.make_spec("tricircle", ["chamber.closing_pressure_kPa=1.9,2.0"])
    assert swept.scene_at(0).chamber.closing_pressure_field == "[chamber].closing_pressure_kPa"


def test_phase_diagram_says_what_it_takes_from_a_scene():
    """The help names the fields --scene takes and says the states are taut (wrinkling = "refuse"); a
    tension-field scene gets a note that its wrinkling is not used."""
    help_text = " ".join(run("phase-diagram", "--help").output.split())
    for words in ("material, jlim and prestretch", "[electrodes] pattern and [layers]", 'wrinkling = "refuse"'):
        assert words in help_text
    r = run("phase-diagram", "--scene", "tricircle", "--points", "3", "--phi-hat", "0,0.1")
    assert r.exit_code == 0, r.output
    assert 'tricircle asks for wrinkling = "tension-field"' in r.output
