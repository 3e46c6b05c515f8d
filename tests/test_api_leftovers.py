"""Leftovers of the fuzz sweep of the Python API (helper-98): a failed voltage search's entries carry no voltage, the
numeric methods of MembraneModel and the list arguments of Simulation name a bad argument in a SceneError, and absurd
prestretches and atmospheric pressures are refused up front."""

import dataclasses

import numpy as np
import pytest
from click.testing import CliRunner
from conftest import bounded, one_line_error, variant, variant_text

from coexist import curves
from coexist.cli.main import cli
from coexist.errors import SceneError
from coexist.model import MembraneModel, build_model
from coexist.scene import parse_scene
from coexist.settings import SolverSettings
from coexist.shooting import NO_VOLTAGE, OK, VOLTAGE_ITERATIONS, WRINKLED_AT_POLE, solve_states
from coexist.simulation import Simulation

P_HAT = 1.2
#: Gent 97 at p̂ = 1.2: no voltage holds 1.05 (p̂(1.05, 0) < 1.2), 1.5–3.0 are held, 3.3 and 3.6 lie beyond the
#: end of the spiral (the pressure stays above 1.2 up to the failing states; test_charge_curve_speed)
GRID = np.array([1.05, 1.5, 2.0, 3.0, 3.3, 3.6])


# --------------------------------------------------------------------------------- 1. failed voltage searches


def test_failed_voltage_searches_carry_no_voltage():
    """A pole stretch without a voltage that carries p̂ had kept the last valid voltage tried (0.337 at 3.3, 0 at
    1.05) as its ``phi_hat`` while every other quantity was NaN: now NaN too, the states found unchanged."""
    s = bounded(curves.voltage_at_pressure, build_model("gent", 97.0), GRID, P_HAT)
    assert s.status.tolist() == [NO_VOLTAGE, OK, OK, OK, NO_VOLTAGE, NO_VOLTAGE]
    assert np.all(np.isnan(s.phi_hat[~s.ok]))
    assert np.all(np.isfinite(s.phi_hat[s.ok])) and np.all(s.phi_hat[s.ok] > 0)
    np.testing.assert_allclose(s.p_hat[s.ok], P_HAT, rtol=1e-9)
    # the voltages found carry the pressure when shot again (to the shooting's tolerance, 1e-10 default)
    again = solve_states(build_model("gent", 97.0), GRID[s.ok], s.phi_hat[s.ok])
    np.testing.assert_allclose(again.p_hat, P_HAT, rtol=1e-9)


def test_a_search_out_of_iterations_carries_no_voltage():
    """``iterations=1``: the searches still open (VOLTAGE_ITERATIONS) had kept their first guess as the voltage."""
    s = bounded(curves.voltage_at_pressure, build_model("gent", 97.0), GRID[:4], 1.5, iterations=1)
    assert s.status.tolist() == [NO_VOLTAGE] + [VOLTAGE_ITERATIONS] * 3
    assert np.all(np.isnan(s.phi_hat))


def test_failed_voltage_searches_of_a_tension_field_model():
    """``wrinkled_stiffness`` is NaN where a state failed (MembraneStates documents it): it had kept the last valid
    state's (inf, taut)."""
    s = bounded(curves.voltage_at_pressure, build_model("gent", 97.0, wrinkling="tension-field"), GRID, P_HAT)
    assert not s.ok.all() and s.ok.any()
    assert np.all(np.isnan(s.phi_hat[~s.ok])) and np.all(np.isnan(s.wrinkled_stiffness[~s.ok]))
    assert np.all(~np.isnan(s.wrinkled_stiffness[s.ok]))


def _failing(states):
    """``states`` as a failed search returns them: a failure status and NaN numbers (the voltage too)."""
    states.status[:] = WRINKLED_AT_POLE
    for name in ("phi_hat", "p_hat", "v_hat", "q_hat", "psi_hat"):
        getattr(states, name)[:] = np.nan
    return states


def test_a_limit_point_whose_own_state_fails_is_not_returned(monkeypatch):
    """The state at the extremum the bracket search located had been made a LimitPoint unchecked: where it fails,
    its numbers were NaN (and its voltage a stale one). It ends the curve before it (``_FailsInside``), as a state
    failing inside the bracket does."""
    model = MembraneModel()
    grid = np.linspace(2.0, 2.4, 5)
    states = solve_states(model, grid, 0.0)
    bracket = curves._Bracket("p_hat", "pressure_max", True, 1, 3)
    monkeypatch.setattr(curves, "chebyshev_extremum", lambda *args, **kwargs: (np.array([2.2]), None))

    def evaluate(x):
        return _failing(solve_states(model, x, 0.0))

    with pytest.raises(curves._FailsInside) as info:
        curves._refine_brackets(states, [bracket], evaluate, SolverSettings())
    assert info.value.pole_stretch == 2.2 and info.value.status == WRINKLED_AT_POLE


def test_a_voltage_limit_point_is_polished_from_its_own_voltage(monkeypatch):
    """The last resort of a Φ̂–Q̂ limit point starts its iteration from the voltage of the states at it; where those
    fail (NaN voltage, as a failed search now says) it starts from the located limit point's, never from NaN (which
    had been a SceneError of solve_states from inside the curve)."""
    model = build_model("gent", 97.0)
    curve = bounded(curves.voltage_charge_curve, model, P_HAT, np.linspace(1.3, 3.2, 40))
    lp = next(lp for lp in curve.limit_points if lp.kind == "voltage_max")
    grid = curve.states.pole_stretch
    i = int(np.searchsorted(grid, lp.pole_stretch))
    bracket = curves._Bracket("phi_hat", "voltage_max", True, i - 1, i)
    monkeypatch.setattr(curves, "_refine_brackets", lambda *args: [dataclasses.replace(lp, errors=None)])

    def evaluate(x):
        return _failing(curves.voltage_at_pressure(model, x, P_HAT))

    found = bounded(curves._from_interpolated_values, model, P_HAT, SolverSettings(), curve.states, [bracket], evaluate)
    assert len(found) == 1 and found[0].kind == "voltage_max"
    # the located limit point, or the iteration from it: the same voltage to the solver's tolerance
    assert abs(found[0].phi_hat - lp.phi_hat) <= 1e-8 * lp.phi_hat
    assert abs(found[0].p_hat - P_HAT) <= 1e-8 * P_HAT


# ------------------------------------------------------------------------------ 2. raw errors of public methods

M = MembraneModel()
A3 = np.full(3, 1.5)
A2 = np.full(2, 1.5)

MODEL_CASES = [
    ("pole(None)", lambda: M.pole(None), "l0"),
    ("pole(l0, phi=None)", lambda: M.pole(A3, None), "phi"),
    ("pole('abc')", lambda: M.pole("abc"), "l0"),
    ("pole([1.5, 2])", lambda: M.pole([1.5, 2.0]), "l0"),
    ("pole(3, 2)", lambda: M.pole(A3, np.full(2, 0.1)), "l0, phi"),
    ("tensions(3, 2)", lambda: M.tensions(A3, A2), "l1, l2, phi"),
    ("tensions(None, 1.5)", lambda: M.tensions(None, 1.5), "l1"),
    ("free_energy(3, 'x')", lambda: M.free_energy(A3, "x"), "l2"),
    ("series_start(3, .1, 2, 1e-3)", lambda: M.series_start(A3, 0.1, np.full(2, 0.1), 1e-3), "l0, p_trial, phi, R0"),
    ("rhs(.5, 3, 2, ...)", lambda: M.rhs(0.5, A3, A2, 0.1, 0.1, 0.1), "R, l1, l2, theta, p, phi"),
    ("rhs(.5, 3, [..], ...)", lambda: M.rhs(0.5, A3, [1.5] * 3, 0.1, 0.1, 0.1), "l2"),
    ("rhs_into(out 3 rows)", lambda: M.rhs_into(0.5, A3, A3, 0.1, 0.1, 0.1, np.zeros((3, 3))), "out"),
    ("rhs_into(out of 2)", lambda: M.rhs_into(0.5, A3, A3, 0.1, 0.1, 0.1, np.zeros((7, 2))), "out"),
    ("rhs_into(out None)", lambda: M.rhs_into(0.5, A3, A3, 0.1, 0.1, 0.1, None), "out"),
    (
        "rhs_sensitivities_into(s_l0=None)",
        lambda: M.rhs_sensitivities_into(0.5, A3, A3, 0.1, 0.1, 0.1, None, [A3] * 3, np.zeros((17, 3))),
        "s_l0",
    ),
    (
        "rhs_sensitivities_into(s_phi of 2)",
        lambda: M.rhs_sensitivities_into(0.5, A3, A3, 0.1, 0.1, 0.1, [A3] * 3, [A3] * 2, np.zeros((17, 3))),
        "s_phi",
    ),
    ("wrinkle_aux of a refusing model", lambda: M.wrinkle_aux(1.5, 1.5), "wrinkling"),
]


@pytest.mark.parametrize("call, field", [c[1:] for c in MODEL_CASES], ids=[c[0] for c in MODEL_CASES])
def test_numeric_methods_name_a_bad_argument(call, field):
    """None, text, lists, shapes that do not broadcast and an ``out`` too small had been raw TypeError, ValueError
    (broadcasting) or a bare ValueError: a SceneError naming the argument(s)."""
    with pytest.raises(SceneError) as info:
        call()
    assert info.value.field == field


def test_numeric_methods_are_unchanged_for_good_arguments():
    """Floats, arrays and 2-D arrays broadcast as before (the check runs only once a call has failed): the
    neo-Hookean pole tension ``T̂0 = λ0 − λ0⁻⁵ − Φ̂² λ0³`` to rounding."""
    l0, phi = np.array([[1.5, 2.0]]), np.array([[0.0], [0.1]])
    t0 = M.pole(l0, phi)[0]
    assert t0.shape == (2, 2)
    np.testing.assert_allclose(t0, l0 - l0**-5 - phi**2 * l0**3, rtol=1e-14)
    assert M.pole(1.5)[0] == pytest.approx(1.5 - 1.5**-5, rel=1e-14)
    out = np.zeros((8, 3))
    assert M.rhs_into(0.5, A3, A3, 0.1, 0.1, 0.1, out) is out and np.all(out[7] == 0)


@pytest.fixture(scope="module")
def sim():
    return Simulation.from_scene(variant(values_kV="[0.0]"))


@pytest.mark.parametrize("value", [None, 3, "segments", [1]])
def test_simulation_list_arguments_are_checked(sim, value):
    """``Simulation.branches(None)`` had raised a raw TypeError (``[1]``: an AttributeError), and so had
    ``measure_segment_ends`` and ``measure_errors``."""
    for call, field in (
        (sim.branches, "segments"),
        (sim.measure_segment_ends, "segments"),
        (sim.measure_errors, "transitions"),
    ):
        with pytest.raises(SceneError) as info:
            call(value)
        assert info.value.field == field
    assert sim.branches([]) == [] and sim.branches(iter([])) == []


# ------------------------------------------------------------------------------------------- 3. prestretch


@pytest.mark.parametrize("prestretch", [1e31, 1e60, 1e200])
def test_absurd_prestretches_are_refused(prestretch):
    """Past a pole stretch of ~1.5e51 every state failed as "the integration used up its step budget" (after 3 s
    per curve), above 1e103 as non-finite values; a prestretch above 1e30 (the scene's bound on every number) is
    refused, by the model and so by build_model and the command line."""
    for make in (lambda: MembraneModel(prestretch=prestretch), lambda: build_model(prestretch=prestretch)):
        with pytest.raises(SceneError, match="at most 1e\\+30") as info:
            make()
        assert info.value.field == "prestretch"
    r = CliRunner().invoke(cli, ["curves", "--prestretch", repr(prestretch), "--p-hat", "none", "--phi-hat", "0"])
    one_line_error(r, "--prestretch", "at most 1e+30")


def test_the_largest_prestretch_is_solved_exactly():
    """At the bound the neo-Hookean states are those of any large prestretch, scaled: ``p̂ λpre``, ``V̂/λpre³``,
    ``Ψ̂/λpre²`` at fixed ``λ0/λpre`` agree with ``λpre = 1e6``'s to 1e-10 (measured: 2e-13 up to 3e50)."""
    x = np.array([1.01, 1.5, 3.0])
    scaled = []
    for pre in (1e6, 1e30):  # coexist.model.MAX_PRESTRETCH
        s = solve_states(build_model(prestretch=pre), pre * x, 0.0).require_ok()
        scaled.append(np.r_[s.p_hat * pre, s.v_hat / pre**3, s.psi_hat / pre**2])
    np.testing.assert_allclose(scaled[1], scaled[0], rtol=1e-10)


# ------------------------------------------------------------------------------------- 4. atmospheric pressure


@pytest.mark.parametrize("kpa", [1e9, 1.01e6])
def test_absurd_atmospheric_pressures_are_refused(tmp_path, kpa):
    """1e9 kPa had been accepted and the ramp stopped (exit 1) with "the gradient flow did not settle (stalled)":
    the gauge pressure's rounding (~1e-16 p̂atm, p̂atm = 8.9e8) exceeds the flow's tolerance. Above 1 GPa the
    scene is refused (exit 2, one line naming the field)."""
    with pytest.raises(SceneError, match="at most 1e\\+06 kPa") as info:
        variant(atmospheric_pressure_kPa=kpa)
    assert info.value.field == "[chamber].atmospheric_pressure_kPa"
    path = tmp_path / "dense.toml"
    path.write_text(variant_text(atmospheric_pressure_kPa=kpa))
    for command in ("check", "ramp"):
        one_line_error(CliRunner().invoke(cli, [command, str(path)]), "[chamber].atmospheric_pressure_kPa", "1 GPa")


@pytest.mark.parametrize("key, value", [("atmospheric_pressure_kPa", 1.1e5), ("atmospheric_pressure_bar", 1e4)])
def test_plausible_atmospheric_pressures_are_accepted(key, value):
    """The deep sea (110 MPa, the Mariana Trench) and the bound itself (1 GPa) are accepted."""
    text = variant_text().replace("atmospheric_pressure_kPa = 101.325", f"{key} = {value}")
    scene = parse_scene(text)
    assert scene.chamber.atmospheric_pressure <= 1e9  # coexist.scene_format.MAX_ATMOSPHERIC_PRESSURE
    assert scene.chamber.atmospheric_pressure == pytest.approx(value * (1e3 if key.endswith("kPa") else 1e5))
