"""The command line as a user runs it: exit codes, JSON structure, files, and no tracebacks."""

import json
import subprocess
import sys

import pytest
from click.testing import CliRunner

from coexist import __version__
from coexist.cli.main import cli


def run(*args):
    return CliRunner().invoke(cli, list(args))


def no_traceback(result):
    return result.exception is None or isinstance(result.exception, SystemExit)


def test_help_and_version():
    assert run("--help").exit_code == 0
    r = run("--version")
    assert r.exit_code == 0 and __version__ in r.output


def test_python_dash_m(tmp_path):
    # run outside the source tree, so the installed package is the one found
    r = subprocess.run(
        [sys.executable, "-m", "coexist", "--version"], capture_output=True, text=True, timeout=60, cwd=tmp_path
    )
    assert r.returncode == 0 and __version__ in r.stdout


@pytest.mark.parametrize("user_setting", [None, "3"])
def test_command_line_blas_threads(tmp_path, user_setting):
    """The command line runs OpenBLAS on one thread (its matrices have a few rows; the thread pool only cost CPU),
    set before numpy loads; a user's own OPENBLAS_NUM_THREADS is kept."""
    import os

    env = {k: v for k, v in os.environ.items() if k != "OPENBLAS_NUM_THREADS"}
    if user_setting is not None:
        env["OPENBLAS_NUM_THREADS"] = user_setting
    code = (
        "import sys, os; import coexist.cli.main; assert 'numpy' not in sys.modules; import numpy; "
        "print(os.environ['OPENBLAS_NUM_THREADS'])"
    )
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60, cwd=tmp_path, env=env)
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip() == (user_setting or "1")


def test_curves_json(tmp_path):
    png = tmp_path / "c.png"
    r = run(
        "curves",
        "--phi-hat",
        "0,0.1",
        "--p-hat",
        "1.5",
        "--points",
        "40",
        "--accuracy",
        "draft",
        "--json",
        "-o",
        str(png),
    )
    assert r.exit_code == 0, r.output
    data = json.loads(r.stdout)
    assert data["settings"]["relative_tolerance"] == 1e-6
    fixed = [c["phi_hat"] if c["family"] == "pressure_volume" else c["p_hat"] for c in data["curves"]]
    assert fixed == [0.0, 0.1, 1.5]
    pv = data["curves"][0]
    for key in ("pole_stretch", "p_hat", "v_hat", "q_hat", "psi_hat", "limit_points"):
        assert key in pv
    assert len(pv["p_hat"]) == 40
    lp = pv["limit_points"][0]
    assert set(lp) >= {"pole_stretch", "p_hat", "v_hat", "phi_hat", "q_hat"}
    assert lp["p_hat"] == pytest.approx(1.8792, abs=1e-3)
    vq = data["curves"][2]
    assert vq["family"] == "voltage_charge" and "starts_because" in vq
    assert vq["p_hat_residual_max"] < 1e-5 and len(vq["phi_hat"]) == len(vq["q_hat"])
    assert png.stat().st_size > 10_000


def test_curves_csv_to_stdout():
    r = run("curves", "--phi-hat", "0.1", "--p-hat", "none", "--points", "10", "--csv", "-")
    assert r.exit_code == 0
    lines = r.stdout.strip().splitlines()
    assert lines[0].startswith("family,") and len(lines) == 11
    # the limit points go beside the CSV, to stderr (they were nowhere; found in review)
    assert "pressure_max" in r.stderr and "pressure_max" not in r.stdout


def test_curves_refuses_to_overwrite(tmp_path):
    out = tmp_path / "c.png"
    out.write_text("keep me")
    r = run("curves", "--p-hat", "none", "--points", "10", "-o", str(out))
    assert r.exit_code == 2 and "--overwrite" in r.output
    assert out.read_text() == "keep me"


@pytest.mark.parametrize(
    "args, option",
    [
        (["--pole-stretch", "0,4"], "--pole-stretch"),
        (["--pole-stretch", "-1,4"], "--pole-stretch"),
        (["--pole-stretch", "3,2"], "--pole-stretch"),
        (["--pole-stretch", "1,4"], "--pole-stretch"),
        (["--pole-stretch", "abc"], "--pole-stretch"),
        (["--material", "gent", "--jlim", "0"], "--jlim"),
        (["--material", "gent", "--jlim", "-5"], "--jlim"),
        (["--material", "gent"], "--jlim"),
        (["--material", "rubber"], "--material"),
        (["--phi-hat", "-0.1"], "--phi-hat"),
        (["--phi-hat", "nan"], "--phi-hat"),
        (["--p-hat", "0"], "--p-hat"),
        (["--prestretch", "0.5"], "--prestretch"),
        (["--accuracy", "extreme"], "--accuracy"),
        (["--rtol", "1"], "--rtol"),
        (["--points", "1"], "--points"),
    ],
)
def test_bad_input_is_exit_2_naming_the_option(args, option):
    r = run("curves", "--p-hat", "none", *args) if "--p-hat" not in args else run("curves", *args)
    assert r.exit_code == 2, r.output
    assert option in r.output
    assert no_traceback(r)
    assert "Traceback" not in r.output


def test_curves_defaults_follow_the_prestretch():
    """``coexist curves --prestretch 3`` runs on its defaults: the pole-stretch range follows the prestretch
    (1.01 λpre to max(4, 1.5 λpre), as the library's), and a default Φ̂–Q̂ pressure no state of this membrane
    reaches is skipped with a note; the same pressure asked for is bad input naming --p-hat, the pressure and
    the reason (exit 2: no state anywhere in the range)."""
    r = CliRunner().invoke(
        cli, ["curves", "--material", "neo-hookean", "--prestretch", "3", "--points", "30", "--json"]
    )
    assert r.exit_code == 0, r.output
    data = json.loads(r.stdout)
    assert data["settings"]["pole_stretch_range"] == [pytest.approx(3.03), pytest.approx(4.5)]
    assert "no Φ̂–Q̂ curve at the default p̂ = 1.2" in r.stderr
    asked = CliRunner().invoke(cli, ["curves", "--material", "neo-hookean", "--prestretch", "3", "--p-hat", "1.2"])
    assert asked.exit_code == 2 and "no voltage" in asked.output and "Traceback" not in asked.output
    assert "Error: --p-hat: the zone has no state at p̂ = 1.2 in pole stretch 3.03..4.5" in asked.output


def test_volume_maximum_does_not_move_with_the_sampling():
    """Found in review: the p̂–V̂ curve's volume maximum was located by the extremum's value settling, its location
    (and the pressure read there) only to about the square root of that: at 50 points λ0 was off by 2e-8 and p̂ by
    1.3e-9 from the rtol-1e-13 reference, printed to 8 and 10 decimals. Now the location settles too (to the
    limit-point tolerance, 1e-9 relative)."""

    def volume_max(*args):
        r = run("curves", "--phi-hat", "0.2", "--p-hat", "none", "--json", *args)
        assert r.exit_code == 0, r.output
        (lp,) = [lp for c in json.loads(r.stdout)["curves"] for lp in c["limit_points"] if lp["kind"] == "volume_max"]
        return lp["pole_stretch"], lp["p_hat"]

    l_ref, p_ref = volume_max("--points", "400", "--rtol", "1e-13")
    for points in ("50", "200"):
        lam, p = volume_max("--points", points)
        assert abs(lam - l_ref) <= 3e-9 * l_ref and abs(p - p_ref) <= 6e-10, (points, lam - l_ref, p - p_ref)


def test_no_state_anywhere_names_every_failure_along_the_range():
    """A prestretched inner-circle electrode at a high voltage (Gent 300, λpre 2.37, Φ̂ = 0.412, two passive layers,
    tension-field) has no state on the grid: the first pole stretch runs out of integration steps, all the others
    wrinkle at the pole. The message had named only the first failure, the odd one out; it names each stretch of
    equal failures now, with where it starts."""
    r = CliRunner().invoke(
        cli,
        ["curves", "--material", "gent", "--jlim", "300", "--prestretch", "2.37", "--wrinkling", "tension-field"]
        + ["--pattern", "inner-circle", "--inner-fraction", "0.45", "--passive-layers", "2", "--phi-hat", "0.412"]
        + ["--p-hat", "none", "--points", "15"],
    )
    assert r.exit_code == 2 and "Traceback" not in r.output
    assert "the zone has no state at Φ̂ = 0.412 in pole stretch 2.394..4 (at 2.394: " in r.output
    assert "from 2.508 to 4 (14 states), at 2.508: the tension at the pole is not positive" in r.output


def test_a_prestretch_that_locks_the_gent_membrane_is_blamed_on_the_prestretch():
    """``coexist curves --prestretch 3 --material gent --jlim 10`` had blamed ``--phi-hat`` ("no state at Φ̂ = 0 ...
    the chains lock"); a scene with the same values names the prestretch, and so does the option now (review,
    helper-71). 2 still runs."""
    r = CliRunner().invoke(cli, ["curves", "--prestretch", "3", "--material", "gent", "--jlim", "10"])
    assert r.exit_code == 2
    (line,) = [x for x in r.output.splitlines() if x.startswith("Error:")]
    assert line == "Error: --prestretch: a prestretch of 3 locks a Gent membrane with jlim = 10"
    ok = ["curves", "--prestretch", "2", "--material", "gent", "--jlim", "10", "--p-hat", "none", "--phi-hat", "0"]
    assert CliRunner().invoke(cli, ok).exit_code == 0


@pytest.mark.parametrize(
    "args", [["ramp", "--rtol", "1e-3"], ["ramp", "nosuchscene"], ["ramp", "--foo"], ["curves", "--points", "abc"]]
)
def test_bad_input_is_one_line_on_stderr_with_exit_code_2(args):
    """Bad input gets one line, ``Error: ...``, and exit code 2: click's usage errors had printed the usage and a hint
    above it, four lines (review, helper-74); click's own faults point to ``--help`` on the same line."""
    import subprocess
    import sys

    r = subprocess.run([sys.executable, "-m", "coexist", *args], capture_output=True, text=True, timeout=120)
    assert r.returncode == 2 and r.stdout == ""
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("Error: ") and "Traceback" not in r.stderr, r.stderr


def test_shape_refuses_a_voltage_given_twice():
    """``shape --voltage-kV 3,3`` printed the same state twice (sweep refuses a repeated value: review, helper-74)."""
    r = CliRunner().invoke(cli, ["shape", "--voltage-kV", "3,4,3"])
    assert r.exit_code == 2 and "3 kV is given more than once" in r.output


def test_a_re_entry_past_a_pull_in_is_marked_as_the_models_convention():
    """The default ramp leaves the model's range at the bulged zone's pull-in (4.336628993 kV) and, coming back down,
    re-enters the state it left there. That is a convention of the model, not a prediction: the table said nothing of
    it (review, helper-77). A line under the transitions says so."""
    r = CliRunner().invoke(cli, ["ramp"])
    assert r.exit_code == 0, r.output
    assert "re_entry           down   4.336628993 kV" in r.output
    assert "(re_entry: coming back below where the states left the model's range" in r.output
