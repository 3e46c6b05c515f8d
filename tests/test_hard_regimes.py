"""Hard regimes (helper-103): Gent membranes that lock barely above 1 (Jlim 0.05 ... 2), alone and prestretched
close to the locking stretch.

``Gent.locking_stretch`` is ``√((Jlim + 3)/2)``, the root of ``2λ² + λ⁻⁴ − 3 = Jlim`` without its ``λ⁻⁴``: an upper
bound, 1.5e-6 high at Jlim 97 but 16 % at Jlim 0.05 (1.235 against 1.068). The end of the pole stretches every
zone curve is followed to was ``0.95`` times it, 1.173 at Jlim 0.05, past where the chains lock: a scene prestretched
to 1.066 (below the locking stretch, accepted by the scene checks) failed in `coexist check` and `coexist ramp` with
"no valid state anywhere in pole stretch 1.068..1.173" (exit 1, a range that is all locked); and `coexist curves
--jlim 0.05 --prestretch 1.06` refused its own default range (1.0706..4, every state locked, exit 2). The exact
locking stretch is checked here against ``brentq``.
"""

from __future__ import annotations

import json
import math

import pytest
from click.testing import CliRunner
from scipy.optimize import brentq

from coexist.cli.main import cli
from coexist.effects import Gent
from coexist.simulation import stretch_range_end

SCENE = """
name = "small-jlim"
description = "three Gent zones locking barely above 1"
[membrane]
material = "gent"
jlim = {jlim}
shear_modulus_kPa = 45
relative_permittivity = 4.7
thickness_mm = 0.5
zone_radius_mm = 21.4165
prestretch = {pre}
wrinkling = "tension-field"
[zones]
count = 3
[chamber]
volume_ml = 300
closing_pressure_mbar = {mbar}
atmospheric_pressure_kPa = 101.325
[voltage]
start_kV = 0
stop_kV = {stop}
step_kV = {step}
"""


def _lock(jlim):
    """The equibiaxial locking stretch, independently (brentq on ``2λ² + λ⁻⁴ − 3 − Jlim``)."""
    return brentq(lambda s: 2 * s * s + s**-4 - 3 - jlim, 1 + 1e-12, 2 * math.sqrt(jlim + 3), xtol=1e-15, rtol=1e-15)


def _run(*args):
    return CliRunner().invoke(cli, list(args))


@pytest.mark.parametrize("jlim", [1e-6, 0.05, 0.3, 1.0, 2.0, 97.0, 1e4])
def test_equibiaxial_locking_stretch_is_the_root(jlim):
    """The exact equibiaxial locking stretch against brentq on ``2λ² + λ⁻⁴ − 3 − Jlim`` (to 1e-12 relative: at Jlim
    1e-6 the function's rounding, ~3ε over its slope 7e-3, leaves both roots uncertain by ~4e-14)."""
    from coexist.effects import equibiaxial_locking_stretch

    ref = _lock(jlim)
    assert equibiaxial_locking_stretch(jlim) == pytest.approx(ref, rel=1e-12, abs=0)
    assert Gent(jlim).exact_locking_stretch == pytest.approx(ref, rel=1e-12, abs=0)
    assert Gent(jlim).locking_stretch >= ref  # the approximate one stays an upper bound


def test_zone_curves_end_before_the_chains_lock():
    """The zone curves' end lies below the exact locking stretch (it was 1.173 at Jlim 0.05, locking at 1.068), and
    is unchanged where Jlim is large (0.95 √50 at Jlim 97)."""
    lock = _lock(0.05)
    end = stretch_range_end(Gent(0.05), 1.0)
    assert end == pytest.approx(lock - 0.05 * (lock - 1), rel=1e-13)
    assert end < lock
    assert stretch_range_end(Gent(97.0), 1.0) == 0.95 * math.sqrt(50.0)


def test_prestretch_near_the_locking_stretch_is_bad_input():
    """A prestretch of 1.066 at Jlim 0.05 (locking at 1.06809): bad input naming the prestretch and its bound
    (exit 2), not "no valid state anywhere" (exit 1) from `check` and `ramp`."""
    import tempfile
    from pathlib import Path

    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "near-lock.toml"
        path.write_text(SCENE.format(jlim=0.05, pre=1.066, mbar=5, stop=5, step=0.5))
        for cmd in ("check", "ramp"):
            r = _run(cmd, str(path))
            assert r.exit_code == 2, (cmd, r.output)
            assert r.exception is None or isinstance(r.exception, SystemExit)
            assert "prestretch" in r.output and "1.06809" in r.output and "below 1.06256" in r.output, r.output


def test_curves_default_range_near_the_locking_stretch():
    """`coexist curves --jlim 0.05 --prestretch 1.06`: its default range lies between the prestretch and the locking
    stretch (it started at 1.0706, past it, and the command refused its own default, exit 2)."""
    r = _run(
        "curves", "--material", "gent", "--jlim", "0.05", "--prestretch", "1.06", "--phi-hat", "0", "--p-hat", "none",
        "--points", "20", "--json",
    )  # fmt: skip
    assert r.exit_code == 0, r.output
    data = json.loads(r.stdout)
    lo, hi = data["settings"]["pole_stretch_range"]
    lock = _lock(0.05)
    assert 1.06 < lo < hi == pytest.approx(lock, rel=1e-13)
    curve = data["curves"][0]
    assert len(curve["p_hat"]) >= 15 and all(math.isfinite(p) and p > 0 for p in curve["p_hat"])


def test_a_pressure_just_above_the_snap_through_reads_above_it(tmp_path):
    """A controlled pressure 1e-7 above p̂max is refused (exit 2) with the two pressures printed apart: at four figures
    both had read ``1.973``."""
    from coexist.scene import load_scene
    from coexist.simulation import snap_through_pressure

    p_max = snap_through_pressure(load_scene("tricircle")).p_hat  # the same membrane, unpatterned, no prestretch
    mbar = p_max * (1 + 1e-7) * 45e3 * 0.5e-3 / 21.4165e-3 / 100  # p = p̂ μH/A
    path = tmp_path / "pressure.toml"
    path.write_text(
        '[membrane]\nmaterial = "gent"\njlim = 97\nshear_modulus_kPa = 45\nrelative_permittivity = 4.7\n'
        f"thickness_mm = 0.5\nzone_radius_mm = 21.4165\n[zones]\ncount = 3\npressure_mbar = {mbar!r}\n"
        "[voltage]\nstop_kV = 1\n"
    )
    result = CliRunner().invoke(cli, ["ramp", str(path)])
    assert result.exit_code == 2 and "Traceback" not in result.output
    (line,) = [x for x in result.output.splitlines() if x.startswith("Error:")]
    given = float(line.split("(p̂ = ")[1].split(")")[0])
    bound = float(line.split("p̂max = ")[1].split()[0].rstrip(",;"))
    assert given > bound
    assert given == pytest.approx(p_max * (1 + 1e-7), rel=1e-7) and bound == pytest.approx(p_max, rel=1e-7)
