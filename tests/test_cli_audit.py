"""The command-line audit's findings, each a test: oversized curves/shape work refused before it starts, output
files written with the permissions open() gives and through symbolic links, errors naming the input at fault,
empty list items refused, no stray progress label on stderr."""

import os
import stat

import pytest
from click.testing import CliRunner
from conftest import one_line_error as refused

from coexist.cli.main import cli
from coexist.cost import MAX_MEMORY_BYTES, MAX_OUTPUT_NUMBERS, curves_cost, shape_cost
from coexist.errors import SceneError
from coexist.files import atomic, real_target
from coexist.scene import builtin_scene_text


def run(args, folder):
    """The CLI in-process in ``folder``: ``(result, files written)``."""
    before = set(os.listdir(folder))
    cwd = os.getcwd()
    os.chdir(folder)
    try:
        result = CliRunner().invoke(cli, args)
    finally:
        os.chdir(cwd)
    return result, set(os.listdir(folder)) - before


def mode(path) -> int:
    return stat.S_IMODE(os.stat(path).st_mode)


@pytest.fixture
def umask_022():
    old = os.umask(0o022)
    try:
        yield
    finally:
        os.umask(old)


# --- 1. oversized work is refused before it starts --------------------------------------------------------------
def test_ten_million_curve_states_are_refused_before_any_work(tmp_path):
    phis = ",".join(f"{0.0001 * i:g}" for i in range(2000))
    args = ["curves", "--phi-hat", phis, "--p-hat", "none", "--points", "5000", "-o", "f.png", "--csv", "f.csv"]
    result, written = run(args, tmp_path)
    line = refused(result, "--points", "2000 curves × 5000 points", "--points 257", "--phi-hat")
    assert "90,000,000 numbers" in line
    assert written == set()


def test_a_shape_too_large_is_refused_before_any_work(tmp_path):
    args = ["shape", "--voltage-kV", "0:4.3:0.0025", "--points", "100001", "--json", "-o", "s.png"]
    result, written = run(args, tmp_path)
    refused(result, "--points", "1721 voltages", "--points 867", "--voltage-kV")
    assert written == set() and result.stdout == ""


def test_the_costs_are_the_model_and_the_fitting_value_fits():
    c = curves_cost(5, 3, 200)  # the default command
    assert (c.numbers, c.memory_bytes) == (9 * 1600, 3.5e3 * 1600)
    assert c.seconds == pytest.approx(0.3 + 200 * (5 * 45e-6 + 3 * 150e-6))
    c.check()
    shape_cost(3, 2, 201).check()  # the README's shape command
    shape_cost(2000, 3, 201).check()  # the most voltages a range gives, default points
    shape_cost(1, 3, 100_001).check()  # the most points at one voltage
    big = curves_cost(2000, 0, 5000)
    assert big.fits == 257
    curves_cost(2000, 0, big.fits).check()  # what the message proposes runs
    assert curves_cost(2000, 0, big.fits + 30).memory_bytes > MAX_MEMORY_BYTES
    s = shape_cost(1721, 3, 100_001)
    shape_cost(1721, 3, s.fits).check()
    assert shape_cost(1721, 3, s.fits + 100).numbers > MAX_OUTPUT_NUMBERS
    # too many curves for even three points each: the lists are named
    with pytest.raises(SceneError) as exc:
        curves_cost(1_000_000, 0, 3).check()
    assert exc.value.field == "--phi-hat" and "fewer values" in str(exc.value)
    # a patterned zone's states cost more memory: fewer fit
    assert curves_cost(40, 0, 5000, patterned=True).memory_bytes == 15e3 * 200_000
    with pytest.raises(SceneError):
        curves_cost(40, 0, 5000, patterned=True).check()


# --- 2. files get open()'s permissions; a symbolic link is written through ---------------------------------------
def test_output_files_get_the_umask_mode(tmp_path, umask_022):
    result, written = run(["curves", "--phi-hat", "0.1", "--p-hat", "none", "--csv", "c.csv", "-o", "a.png"], tmp_path)
    assert result.exit_code == 0, result.output
    assert written == {"c.csv", "a.png"}
    assert mode(tmp_path / "c.csv") == 0o644 and mode(tmp_path / "a.png") == 0o644
    os.umask(0o027)
    result, written = run(["curves", "--phi-hat", "0.1", "--p-hat", "none", "--csv", "d.csv"], tmp_path)
    assert result.exit_code == 0 and mode(tmp_path / "d.csv") == 0o640


def test_overwrite_keeps_a_replaced_files_mode_and_writes_through_a_symlink(tmp_path, umask_022):
    real = tmp_path / "real.csv"
    real.write_text("old\n")
    real.chmod(0o600)
    (tmp_path / "link.csv").symlink_to("real.csv")
    args = ["curves", "--phi-hat", "0.1", "--p-hat", "none", "--csv", "link.csv"]
    result, _ = run(args, tmp_path)
    refused(result, "--csv", "exists", "--overwrite")
    assert real.read_text() == "old\n"
    result, written = run([*args, "--overwrite"], tmp_path)
    assert result.exit_code == 0, result.output
    assert written == set()  # no temporary file left, nothing beside the link
    assert (tmp_path / "link.csv").is_symlink() and os.readlink(tmp_path / "link.csv") == "real.csv"
    assert real.read_text().startswith("family,") and mode(real) == 0o600


def test_a_link_into_another_folder_is_written_there(tmp_path, umask_022):
    other = tmp_path / "other"
    other.mkdir()
    (other / "fig.png").write_bytes(b"old")
    here = tmp_path / "here"
    here.mkdir()
    (here / "fig.png").symlink_to(other / "fig.png")
    result, _ = run(["curves", "--phi-hat", "0.1", "--p-hat", "none", "-o", "fig.png", "--overwrite"], here)
    assert result.exit_code == 0, result.output
    assert (here / "fig.png").is_symlink() and real_target(here / "fig.png") == other / "fig.png"
    assert (other / "fig.png").read_bytes()[:4] == b"\x89PNG"
    assert sorted(os.listdir(other)) == ["fig.png"] and sorted(os.listdir(here)) == ["fig.png"]


def test_a_symlink_loop_is_refused(tmp_path):
    (tmp_path / "a.csv").symlink_to("b.csv")
    (tmp_path / "b.csv").symlink_to("a.csv")
    result, _ = run(["curves", "--phi-hat", "0.1", "--p-hat", "none", "--csv", "a.csv", "--overwrite"], tmp_path)
    refused(result, "--csv", "a.csv")


def test_atomic_leaves_the_target_on_failure_and_uses_the_umask(tmp_path, umask_022):
    target = tmp_path / "t.txt"
    target.write_text("kept")
    with pytest.raises(RuntimeError):
        with atomic(target) as tmp:
            tmp.write_text("half")
            raise RuntimeError("boom")
    assert target.read_text() == "kept" and os.listdir(tmp_path) == ["t.txt"]
    with atomic(tmp_path / "new.txt") as tmp:
        tmp.write_text("whole")
    assert (tmp_path / "new.txt").read_text() == "whole" and mode(tmp_path / "new.txt") == 0o644


def test_save_figure_writes_through_a_symlink(tmp_path, umask_022):
    from coexist.plotting import pyplot, save_figure

    (tmp_path / "real.png").write_bytes(b"old")
    (tmp_path / "link.png").symlink_to("real.png")
    fig = pyplot().figure()
    save_figure(fig, tmp_path / "link.png")
    assert (tmp_path / "link.png").is_symlink()
    assert (tmp_path / "real.png").read_bytes()[:4] == b"\x89PNG"
    assert sorted(os.listdir(tmp_path)) == ["link.png", "real.png"]


# --- 3. errors name the input at fault -------------------------------------------------------------------------
def test_a_voltage_with_no_state_anywhere_names_the_voltage(tmp_path):
    result, written = run(["curves", "--phi-hat", "0.1,5", "-o", "f.png", "--csv", "f.csv"], tmp_path)
    refused(result, "--phi-hat", "Φ̂ = 5", "pole stretch 1.01..4")
    assert written == set()


def test_a_pressure_with_no_state_anywhere_names_the_pressure(tmp_path):
    result, written = run(["curves", "--phi-hat", "0.1", "--p-hat", "1.5,100", "--csv", "f.csv"], tmp_path)
    line = refused(result, "--p-hat", "p̂ = 100")
    assert "p̂ = 1.5" not in line
    assert written == set()


def test_a_bad_accuracy_names_accuracy(tmp_path):
    line = refused(run(["curves", "--accuracy", "0"], tmp_path)[0], "--accuracy")
    assert "--rtol" not in line
    refused(run(["curves", "--rtol", "0"], tmp_path)[0], "--rtol")


@pytest.mark.parametrize("value", ["inf", "nan", "-1"])
def test_a_bad_transition_voltage_names_the_option(tmp_path, value):
    line = refused(run(["fit", "--transition-kV", value], tmp_path)[0], "--transition-kV")
    assert "target_voltage" not in line


def test_a_scene_error_found_while_computing_names_the_file(tmp_path):
    text = builtin_scene_text("tricircle").replace("closing_pressure_mbar = 20", "closing_pressure_mbar = 1e-9")
    (tmp_path / "low.toml").write_text(text)
    result, written = run(["ramp", "low.toml", "-o", "r.png"], tmp_path)
    line = refused(result, "[chamber].closing_pressure_mbar")
    assert line.startswith("Error: low.toml: [chamber].closing_pressure_mbar: ")
    assert written == set()
    # `coexist check` says the same (it called this scene "a stable start")
    checked = refused(run(["check", "low.toml"], tmp_path)[0], "[chamber].closing_pressure_mbar")
    assert "below the smallest computed state" in checked and "below the smallest computed state" in line


def test_bulged_counts_must_be_whole(tmp_path):
    refused(run(["coexistence", "--bulged", "1.5"], tmp_path)[0], "--bulged", "integer")


# --- 5. empty items of a list are refused ----------------------------------------------------------------------
@pytest.mark.parametrize(
    "args, option",
    [
        (["curves", "--phi-hat", "0.1,,0.2"], "--phi-hat"),
        (["curves", "--phi-hat", "0.1,"], "--phi-hat"),
        (["curves", "--p-hat", ",1.5"], "--p-hat"),
        (["curves", "--pole-stretch", "1.1,,3"], "--pole-stretch"),
        (["shape", "--voltage-kV", "0,,1"], "--voltage-kV"),
        (["coexistence", "--bulged", "1,,2"], "--bulged"),
        (["phase-diagram", "--phi-hat", "0,,0.2"], "--phi-hat"),
        (["accuracy", "--study", "1e-6,,1e-8"], "--study"),
        (["sweep", "--vary", "zones.count=2,,3"], "--vary"),
    ],
)
def test_an_empty_list_item_is_refused(tmp_path, args, option):
    line = refused(run(args, tmp_path)[0], option, "empty item")
    assert "item 2" in line or "item 1" in line


# --- 6. no stray progress label -------------------------------------------------------------------------------
def test_no_bare_progress_label_on_stderr(tmp_path):
    result, _ = run(["ramp", "--every", "100"], tmp_path)
    assert result.exit_code == 0, result.output
    assert "ramp" not in result.stderr.splitlines()
    assert any(ln.startswith("following the stable states") for ln in result.stderr.splitlines())


def test_a_fit_says_when_no_stable_state_follows_the_spinodal(tmp_path):
    """At 18 mbar the homogeneous state is lost at a split after which no stable state exists (a zone reaches a
    volume fold): the fit's spinodal is that loss, and it says so (second audit); at the default scene a zone
    bulges there, and there is no note."""
    import json

    text = builtin_scene_text("tricircle").replace("closing_pressure_mbar = 20", "closing_pressure_mbar = 18")
    (tmp_path / "t18.toml").write_text(text)
    r = CliRunner().invoke(
        cli, ["fit", str(tmp_path / "t18.toml"), "--transition-kV", "4.4", "--no-sensitivity", "--json"]
    )
    assert r.exit_code == 0, r.output
    data = json.loads(r.stdout)
    assert data["zone_radius_mm"] == pytest.approx(23.462605, abs=1e-5)
    assert "no stable state follows" in data["note"] and "no_stable_state [split]" in data["note"]
    r = CliRunner().invoke(cli, ["fit", "--transition-kV", "3.9", "--no-sensitivity", "--json"])
    assert r.exit_code == 0 and json.loads(r.stdout)["note"] is None
