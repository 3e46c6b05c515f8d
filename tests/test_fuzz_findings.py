"""What a command-line fuzz sweep found (helper-95, 560 cases), each a test that failed before its fix.

1. ``--overwrite`` through a path whose file is a FIFO (or a device) replaced that node with a regular file (a link
   to ``/dev/full`` left a regular file in its place); it is refused, and ``coexist.files.atomic`` refuses it too.
2. A tiny electrode disc (``inner_fraction = 1e-4``) had the interface-scale floor (two series radii over the disc)
   above every state: the whole curve was called ``BELOW_FLAT``, and the curve's later states, never started, were
   returned as OK with NaN values (``coexist curves --csv`` printed rows of ``nan``, ``check`` an internal error).
   The pole series now starts inside a small pole region, and a state never started is not OK. Checked against the
   analytical limit: as the disc shrinks, the pressure maximum tends to the passive two-layer zone's as ``f²``.
3. A full disk (or stdout on one) was an "internal error"; it is one line, exit code 1.
4. ``coexist shape`` said a closing pressure below every computed state was above the zone's largest.
5. ``coexist check`` printed a ramp cost for a scene that nothing holds at a pressure (no ``[chamber]``, no
   ``[zones].pressure_mbar``), which ``coexist ramp`` then refused.
"""

import os
import stat
import subprocess
import sys

import numpy as np
import pytest
from click.testing import CliRunner
from conftest import complete_scene
from conftest import one_line_error as refused

from coexist import patterned
from coexist.cli.main import cli
from coexist.curves import pressure_volume_curve
from coexist.errors import SceneError
from coexist.files import atomic
from coexist.model import build_model
from coexist.patterned import PatternedModel, ZonePattern
from coexist.scene import builtin_scene_text


def run(args, folder):
    cwd = os.getcwd()
    os.chdir(folder)
    try:
        return CliRunner().invoke(cli, args)
    finally:
        os.chdir(cwd)


# --- 1. a FIFO (or device) is never replaced -------------------------------------------------------------------
@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs here")
def test_overwrite_refuses_a_fifo_and_a_link_to_one(tmp_path):
    os.mkfifo(tmp_path / "pipe.csv")
    (tmp_path / "link.csv").symlink_to("pipe.csv")
    for name in ("pipe.csv", "link.csv"):
        args = ["curves", "--phi-hat", "0.1", "--p-hat", "none", "--points", "20", "--csv", name, "--overwrite"]
        refused(run(args, tmp_path), "--csv", name, "not a regular file")
        assert stat.S_ISFIFO(os.stat(tmp_path / "pipe.csv").st_mode)
    assert sorted(os.listdir(tmp_path)) == ["link.csv", "pipe.csv"]


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs here")
def test_atomic_refuses_a_fifo(tmp_path):
    os.mkfifo(tmp_path / "pipe.txt")
    with pytest.raises(SceneError, match="not a regular file"):
        with atomic(tmp_path / "pipe.txt") as tmp:
            tmp.write_text("x")
    assert stat.S_ISFIFO(os.stat(tmp_path / "pipe.txt").st_mode) and os.listdir(tmp_path) == ["pipe.txt"]


# --- 2. a tiny electrode disc ----------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def gent():
    return build_model("gent", jlim=97.0, voltage=True, prestretch=1.0)


def _pressure_max(model, pattern, phi=0.2):
    c = pressure_volume_curve(PatternedModel.of(model, pattern), phi)
    assert np.all(np.isfinite(c.states.p_hat))
    return next(lp for lp in c.limit_points if lp.kind == "pressure_max")


def test_a_tiny_disc_tends_to_the_passive_zone_as_its_area(gent):
    """``p̂max(f) − p̂max(passive) ∝ f²`` (the disc's area): measured 1.6e-5 at f = 1e-3 and 1.6e-7 at 1e-4 (the
    curve at 1e-4 had no state at all: every one ``BELOW_FLAT``). Their ratio is 100 to 1 % (each ± 5e-10)."""
    passive = _pressure_max(gent, ZonePattern.no_electrode(2)).p_hat
    d3 = passive - _pressure_max(gent, ZonePattern.inner_circle(1e-3, 2)).p_hat
    tiny = _pressure_max(gent, ZonePattern.inner_circle(1e-4, 2))
    d4 = passive - tiny.p_hat
    assert abs(d3 - 1.611418e-5) < 2e-9, d3  # measured 1.6114181e-5; each p̂max is located to ± 5e-10
    assert abs(d3 / d4 / 100 - 1) < 0.01, (d3, d4)
    # the one-layer disc at Φ̂ = 0.2 (the passive zone's 2.467): measured 3.6135556
    assert abs(tiny.pole_stretch - 3.6135556) < 1e-6, tiny.pole_stretch


def test_a_state_never_started_is_not_ok(tmp_path, monkeypatch):
    """With the floor as it was (the series radius not fitted to the pole region), the coarse states of the tiny
    disc's curve end at the floor in one pass, and a state waiting to join them was never started: it came back OK
    with NaN values, the curve's one "valid" state (``--csv`` printed a row of ``nan``). Now it fails (and is
    retried from the cap, which fails the same way): no curve, exit code 1."""
    monkeypatch.setattr(patterned, "FLOOR_SCALE_MAX", 1e6)
    text = builtin_scene_text("inner-circle").replace("inner_fraction = 0.5", "inner_fraction = 1e-4")
    (tmp_path / "tiny.toml").write_text(text)
    result = run(["curves", "--scene", "tiny.toml", "--phi-hat", "0.2", "--p-hat", "none", "--csv", "-"], tmp_path)
    assert "nan" not in result.stdout.lower()
    assert result.exit_code in (1, 2) and "no pressure holds a pole stretch this small" in result.output


def test_the_tiny_disc_scene_from_the_command_line(tmp_path):
    text = builtin_scene_text("inner-circle").replace("inner_fraction = 0.5", "inner_fraction = 1e-4")
    assert "inner_fraction = 1e-4" in text
    (tmp_path / "tiny.toml").write_text(text)
    checked = run(["check", "tiny.toml"], tmp_path)
    assert checked.exit_code == 0, checked.output
    assert "a stable start" in checked.output
    result = run(["curves", "--scene", "tiny.toml", "--phi-hat", "0,0.2", "--p-hat", "none", "--csv", "-"], tmp_path)
    assert result.exit_code == 0, result.output
    assert "nan" not in result.stdout.lower() and result.stdout.count("\n") > 300


# --- 3. a full disk ---------------------------------------------------------------------------------------------
@pytest.mark.skipif(not os.path.exists("/dev/full"), reason="no /dev/full here")
def test_stdout_on_a_full_disk_is_one_line_and_exit_1(tmp_path):
    with open("/dev/full", "w") as full:  # written to, never replaced
        done = subprocess.run(
            [sys.executable, "-m", "coexist", "curves", "--phi-hat", "0.1", "--p-hat", "none", "--csv", "-"],
            stdout=full,
            stderr=subprocess.PIPE,
            text=True,
            cwd=tmp_path,
            timeout=120,
        )
    lines = done.stderr.strip().splitlines()
    assert done.returncode == 1, done.stderr
    assert lines[-1].startswith("Error: cannot write the output") and "No space left" in lines[-1]
    assert "internal error" not in done.stderr and "Traceback" not in done.stderr


# --- 4. shape: a closing pressure below every computed state ----------------------------------------------------
def test_shape_says_below_the_smallest_state(tmp_path):
    """A prestretched neo-Hookean ring (helper-92's s7_26): ``check`` says the closing pressure is below the smallest
    computed state; ``shape`` had said the zone cannot hold it, its largest pressure being above it."""
    scene = complete_scene(
        """name = "low"
[membrane]
material = "neo-hookean"
prestretch = 2.0
wrinkling = "tension-field"
[chamber]
volume_ml = 1e+06
closing_pressure_mbar = 20.8125
[voltage]
start_kV = 0
stop_kV = 12
step_kV = 0.1
[electrodes]
pattern = "ring"
inner_fraction = 0.3
outer_fraction = 0.6
[layers]
passive = 3
"""
    )
    (tmp_path / "low.toml").write_text(scene)
    for command in ("check", "shape"):
        line = refused(run([command, "low.toml"], tmp_path), "[chamber].closing_pressure_mbar")
        assert "below the smallest computed state" in line and "cannot hold" not in line


# --- 5. check: a scene nothing holds at a pressure ---------------------------------------------------------------
def test_check_says_what_a_scene_without_a_chamber_is_for(tmp_path):
    text = builtin_scene_text("tricircle")
    start = text.index("[chamber]")
    end = text.index("[", start + 1)
    (tmp_path / "open.toml").write_text(text[:start] + text[end:])
    checked = run(["check", "open.toml"], tmp_path)
    assert checked.exit_code == 0, checked.output
    assert "ramp cost" not in checked.output and "no [chamber] and no [zones].pressure_mbar" in checked.output
    refused(run(["ramp", "open.toml"], tmp_path), "[chamber]", "needs a [chamber]")


def test_ramp_refuses_a_scene_without_voltage_before_it_starts(tmp_path):
    result = run(["ramp", "two-balloons"], tmp_path)
    refused(result, "[voltage]", "nothing to ramp")
    assert "following the stable states" not in result.output


@pytest.mark.parametrize("name", ["", "  "])
def test_an_empty_scene_name_is_refused_as_such(tmp_path, name):
    line = refused(run(["check", name], tmp_path), "scene name is empty")
    assert "folder" not in line


def test_curves_of_a_scene_past_the_default_range_say_how_far(tmp_path):
    """A prestretched inner circle in a five-layer annulus (helper-95's q32): its flat zone's pole stretch lies above
    the default range (3.03..4.5), where every state is below it; the refusal names the scene's own range, and that
    range has the curve (its pressure maximum at λ0 = 10.1)."""
    scene = complete_scene(
        """name = "far"
[membrane]
material = "neo-hookean"
shear_modulus_kPa = 1000
zone_radius_mm = 100
prestretch = 3.0
wrinkling = "tension-field"
[chamber]
volume_ml = 10000.0
closing_pressure_mbar = 158.27
[electrodes]
pattern = "inner-circle"
inner_fraction = 0.01
[layers]
passive = 5
"""
    )
    (tmp_path / "far.toml").write_text(scene)
    args = ["curves", "--scene", "far.toml", "--phi-hat", "0", "--p-hat", "none"]
    refused(run(args, tmp_path), "--phi-hat", "--pole-stretch 3.03,18")
    result = run([*args, "--pole-stretch", "3.03,18", "--points", "60"], tmp_path)
    assert result.exit_code == 0, result.output
    assert "pressure_max" in result.output


def test_another_os_error_is_still_one_line(monkeypatch, capsys):
    """Only a full disk (ENOSPC and kin) is "cannot write the output"; any other OSError stays the one-line internal
    error it was (the first version of that handler re-raised it: a traceback)."""
    import errno

    import coexist.scene
    from coexist.cli.main import main

    def denied(*args, **kwargs):
        raise PermissionError(errno.EACCES, "Permission denied", "x.toml")

    monkeypatch.setattr(coexist.scene, "load_scene", denied)
    monkeypatch.delenv("COEXIST_DEBUG", raising=False)
    monkeypatch.setattr(sys, "argv", ["coexist", "check", "x.toml"])
    with pytest.raises(SystemExit) as exit_:
        main()
    err = capsys.readouterr().err.strip().splitlines()
    assert exit_.value.code == 1 and len(err) == 1 and err[0].startswith("internal error: PermissionError")
