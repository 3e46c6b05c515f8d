"""The ramp at the loose tolerances its CLI accepts (``--rtol`` 1e-6 … 1e-9) against the default rtol 1e-10: every
transition within the loose run's printed error of the default one, and of the same kind.

Two defects a review found (helper-73), each asserted here on the scene that showed it:

* **The bulged zone's end.** Past the onset of wrinkling the bulged zone's tension-field band carries it 5 V further,
  to the band's pull-in (4.336628993 kV in the default scene). A taut branch that fails within a continuation step
  is ended at the onset only when no state past the onset carries a band; at rtol 1e-7 the long step was probed
  only 1/8 of the way on (past the pull-in) and at the onset (within its bracket, taut), and the taut states there
  stepped over the hoop tension's narrow dip: the onset, 4.3321 kV ± 8e-4, was printed as the end. Six-zone scene
  at 1e-8: 4.2904336 ± 4e-7 against 4.296584402 (14 000 times the error). The band is now looked for at 8⁻¹ … 8⁻⁶ of
  the step, and by states at rtol/100 too.
* **The gas amount's error.** The gas is closed with the zones' volume at the closing pressure; the tight
  re-location that measures a transition's error used the loose run's gas, so the error left out the gas amount's
  (the transitions move by 60–85 kV per unit relative change of it): Gent 300 at 5e-7, the split 1.4892580 ±
  1.3e-5 against 1.4891977 (4.6×), the equal-free-energy voltage 1.0103243 ± 8e-6 against 1.0102472 (9.6×).

* **Two zones at draft and at 5e-7** failed (exit 1). At draft, the landing of the merge on the way down (2.4e-6
  below it) converged within the loose residual tolerance to a 1-of-2 state next to the pitchfork, on the lost
  segment again, which the ramp then asked for 0 V: a landing outside the segment traced through it is refused now
  (further from the merge it lands on the homogeneous segment). At 5e-7 the merge fell 1.3e-7 below the split, and
  the equal-free-energy search in that overlap asked the 1-of-2 segment for states at its pitchfork: segments that
  overlap only within the errors of a split meeting a merge hold one state there and are not compared.

Measured after the fixes (kV, loose ± printed error, default):

======== ====== =========================== ================
scene    rtol   transition                  default
======== ====== =========================== ================
default  1e-7   end 4.3366289 ± 4.4e-6      4.3366290
6 zones  1e-8   end 4.2965844 ± 4.3e-7      4.2965844
6 zones  5e-7   end 4.2965914 ± 3.8e-5      4.2965844
Gent 300 5e-7   split 1.4892580 ± 1.3e-4    1.4891977
Gent 300 5e-7   EFE 1.0103243 ± 1.6e-4      1.0102472
2 zones  1e-6   merge 3.8521581 ± 4.6e-5    3.8521552
2 zones  5e-7   merge 3.8521539 ± 2.4e-5    3.8521552
======== ====== =========================== ================
"""

from __future__ import annotations

import json
import re

import pytest
from click.testing import CliRunner
from conftest import variant_text

from coexist.cli.main import cli
from coexist.scene import builtin_scene_text


def transitions(tmp_path, text, *options):
    path = tmp_path / "scene.toml"
    path.write_text(text)
    result = CliRunner().invoke(cli, ["ramp", str(path), "--json", *options])
    assert result.exit_code == 0, result.output
    return json.loads(result.stdout)["transitions"]


CASES = {
    "default scene at 1e-7": ({}, "1e-7"),
    "six zones at 1e-8": ({"count": 6}, "1e-8"),
    "Gent 300 at 5e-7": ({"jlim": 300.0}, "5e-7"),
    "two zones at draft": ({"count": 2}, "1e-6"),
    "two zones at 5e-7": ({"count": 2}, "5e-7"),
    # a landing of 1 + 1 + 1 zones, converged, did not converge again as a seed: exit 1 (review, helper-81)
    "1e6 ml chamber at draft": ({"volume_ml": "1e6"}, "1e-6"),
}


@pytest.mark.parametrize("name", list(CASES))
def test_loose_transitions_lie_within_their_errors_of_the_default_ones(name, tmp_path):
    changes, rtol = CASES[name]
    text = variant_text(**changes)
    loose = transitions(tmp_path, text, "--rtol", rtol)
    exact = transitions(tmp_path, text)
    key = lambda t: (t["direction"], t["event"], t["kind"])  # noqa: E731
    assert [key(t) for t in loose] == [key(t) for t in exact]
    for a, b in zip(loose, exact):
        assert a["reason"] == b["reason"], (a, b)
        assert a["error_measured"], a
        # the default run's own error (≤ 1e-8 kV) is far below the loose one's
        assert abs(a["voltage_kV"] - b["voltage_kV"]) <= a["voltage_error_kV"] + b["voltage_error_kV"], (a, b)
    ends = [t for t in loose if t["event"] == "range_end" and t["direction"] == "up"]
    assert ends and all("leaves the model's range: electromechanical_instability" in t["reason"] for t in ends), ends


def test_a_fold_and_a_split_at_one_voltage_are_named_the_split_at_every_accuracy(tmp_path):
    """Identical zones under pressure control: the symmetric and antisymmetric modes are one ``dp̂/dV̂`` and vanish
    together, so the homogeneous state's fold and split are one event. Whichever rounding located first named it:
    ``fold`` at the default accuracy, ``split`` at high (review, helper-73). It is the split at both (as in the limit
    of a stiff chamber's gas, where the split comes first), at one voltage."""
    text = builtin_scene_text("tricircle")
    text = re.sub(r"\[chamber\][^\[]*", "", text)
    text = re.sub(r"^count = 3$", "count = 3\npressure_mbar = 20", text, flags=re.M)
    runs = [transitions(tmp_path, text, *opts) for opts in ([], ["--accuracy", "high"])]
    ups = [[t for t in run if t["kind"] == "spinodal" and t["direction"] == "up"] for run in runs]
    assert [[t["event"] for t in up] for up in ups] == [["split"], ["split"]]
    (a,), (b,) = ups
    assert abs(a["voltage_kV"] - b["voltage_kV"]) <= a["voltage_error_kV"] + b["voltage_error_kV"]
