"""Defects of the Python API found by a fuzzing review (helper-62), each reproduced before its fix."""

import numpy as np
import pytest

from coexist import build_model
from coexist.coexistence import phase_diagram
from coexist.errors import SceneError
from coexist.scene import builtin_scene_text, parse_scene
from coexist.settings import SolverSettings
from coexist.shooting import NOT_FINITE, solve_states
from coexist.simulation import Simulation, snap_through_pressure


def test_phase_diagram_past_the_model_range_is_the_same_diagram():
    """Gent Jlim 97 locks near λ0 ≈ 7: a grid to λ0 = 100 or 1e4 put about 30 of its points on the curve and gave a
    spinodal 1.6 % off (1.76834 for 1.74087) with an error of 1.8e-10, or a 'minimum' above the maximum, and no
    binodal. Now the curves end at the model's range (a note says so) and give the diagram of λ0 ≤ 6.3."""
    g = build_model("gent", 97.0)
    ref = phase_diagram(g, [0.1], 6.3)
    for top in (100.0, 1e4):
        pd = phase_diagram(g, [0.1], top)
        assert any("beyond the model's range" in n for n in pd.notes)
        for name in ("spinodal_max", "spinodal_min", "binodal"):
            assert getattr(pd, name)[0] == pytest.approx(getattr(ref, name)[0], rel=1e-9), (top, name)
    assert ref.spinodal_min[0] == pytest.approx(1.74087288, rel=1e-8)


@pytest.mark.parametrize("jlim", ["1e20", "1e22"])
def test_snap_through_of_a_nearly_neo_hookean_gent_material(jlim):
    """A Gent Jlim of 1e22 reaches λ0 ≈ 7e10 before locking: the snap-through search laid its 80 points over that
    range, found one valid state and reported 'no snap-through: near Gent locking' at p̂ = 0.0024; at 1e20 the
    maximum was off by 1.4e-7. Jlim → ∞ is neo-Hookean: p̂max = 1.87917347 at λ0 = 2.19594."""
    snap = snap_through_pressure(parse_scene(builtin_scene_text("tricircle").replace("jlim = 97", f"jlim = {jlim}")))
    assert snap.maximum
    assert snap.p_hat == pytest.approx(1.8791734688, rel=1e-9)
    assert snap.pole_stretch == pytest.approx(2.1959445, rel=1e-7)


@pytest.mark.parametrize(
    "kwargs, field",
    [
        ({"pole_radius": 0.5}, "pole_radius"),
        ({"pole_radius": 0.01}, "pole_radius"),
        ({"atol_factor": 1e8}, "atol_factor"),
    ],
)
def test_settings_that_would_give_wrong_states_are_refused(kwargs, field):
    """``pole_radius = 0.5`` gave states 6 % off marked OK (the pole series is accurate to O(R0⁴)); ``atol_factor =
    1e8`` gave 8e-5 errors silently."""
    with pytest.raises(SceneError) as exc:
        SolverSettings(**kwargs)
    assert exc.value.field == field
    SolverSettings(pole_radius=1e-3)  # the largest default, and anything up to rtol^(1/4), is fine
    SolverSettings(rtol=1e-8, pole_radius=0.01)


@pytest.mark.parametrize(
    "call",
    [
        lambda: build_model(prestretch="x"),
        lambda: build_model(prestretch=None),
        lambda: build_model(prestretch=True),
        lambda: build_model("gent", jlim="x"),
        lambda: build_model("gent", jlim=True),
        lambda: SolverSettings().with_rtol("x"),
        lambda: SolverSettings.from_accuracy([1e-8]),
    ],
)
def test_bad_argument_types_are_scene_errors(call):
    """These raised a bare ValueError or TypeError (``float(...)`` before the check), or took True for 1."""
    with pytest.raises(SceneError):
        call()


def test_an_overflowing_pole_tension_is_not_a_wrinkle():
    """λ0 = 1e150 overflows the pole tension to a non-finite value: it was reported as wrinkling at the pole."""
    st = solve_states(build_model("neo-hookean"), np.array([1e150]), 0.0)
    assert st.status[0] == NOT_FINITE


def test_equilibria_at_checks_the_numbers_of_bulged_zones():
    """``bulged=[5]`` on three zones silently listed only the homogeneous state; ``bulged=1`` raised a TypeError."""
    sim = Simulation.from_scene(parse_scene(builtin_scene_text("tricircle")), SolverSettings(rtol=1e-8))
    for bad in ([5], [0], [1.5], "12"):
        with pytest.raises(SceneError) as exc:
            sim.equilibria_at(0.23, bulged=bad)
        assert exc.value.field == "bulged"
    one = sim.equilibria_at(0.23, bulged=1)
    assert one == sim.equilibria_at(0.23, bulged=[1])
    assert any(e.configuration.counts != (3,) for e in one)


@pytest.fixture(scope="module")
def tricircle():
    return parse_scene(builtin_scene_text("tricircle"))


@pytest.mark.parametrize(
    "kwargs, field",
    [
        ({"phi_window": (0.3, 0)}, "phi_window"),  # silently found nothing
        ({"phi_window": (0.1, 0.3)}, "phi_window"),  # the closing state outside: no transition found, silently
        ({"phi_window": (0, float("nan"))}, "phi_window"),
        ({"phi_window": (-1, 0.3)}, "phi_window"),  # named phi_hat
        ({"phi_window": (0,)}, "phi_window"),  # IndexError
        ({"phi_window": 5}, "phi_window"),  # TypeError
        ({"snap": (1.0,)}, "snap"),  # IndexError
        ({"snap": (float("nan"), 2.0)}, "snap"),
        ({"model": "x"}, "model"),  # AttributeError
    ],
)
def test_simulation_arguments_are_checked(tricircle, kwargs, field):
    with pytest.raises(SceneError) as exc:
        Simulation.from_scene(tricircle, SolverSettings(rtol=1e-8), **kwargs)
    assert exc.value.field == field


@pytest.mark.parametrize(
    "settings, field",
    [({"locking_margin": 0.1}, "locking_margin"), ({"stretch_max_factor": 1.001}, "stretch_max_factor")],
)
def test_settings_that_leave_no_range_name_themselves(settings, field):
    """They were reported as 'pole_stretch: must be finite numbers' (a grid of NaN) or 'must increase'."""
    text = builtin_scene_text("tricircle")
    if field == "stretch_max_factor":
        text = text.replace('material = "gent"', 'material = "neo-hookean"').replace("jlim = 97\n", "")
    with pytest.raises(SceneError) as exc:
        Simulation.from_scene(parse_scene(text), SolverSettings(**settings))
    assert exc.value.field == field


def test_wrong_types_deeper_in_the_api_are_scene_errors(tricircle):
    """Each raised a bare TypeError, ValueError or AttributeError, or named another input."""
    from coexist.effects import GasChamber
    from coexist.equilibria import Configuration
    from coexist.fit import fit_zone_radius
    from coexist.zone_curves import ZoneCurve

    cases = [
        (lambda: GasChamber.closed_at(None, 1, 0.5, 0.2), "chamber_volume"),
        (lambda: GasChamber.closed_at(1, 1, -2, 0.2), "closing_pressure"),  # named gas_amount
        (lambda: Configuration(3), "configuration"),
        (lambda: Configuration("ab"), "configuration"),
        (lambda: Configuration((1.7, 2)), "configuration"),  # silently (1, 2)
        (lambda: tricircle.p_hat("x"), "p"),
        (lambda: tricircle.phi_hat("x"), "volts"),
        (lambda: fit_zone_radius(tricircle, 3900, bracket_mm=5), "bracket_mm"),
        (lambda: fit_zone_radius(tricircle, 3900, bracket_mm=(10,)), "bracket_mm"),
        (lambda: fit_zone_radius(tricircle, 3900, shared="x"), "shared"),
        (lambda: ZoneCurve.compute(build_model("gent", 97.0), 0.1, [2.0, 1.5, 3.0, 2.5, 4.0, 3.5]), "pole_stretch"),
    ]
    for call, field in cases:
        with pytest.raises(SceneError) as exc:
            call()
        assert exc.value.field == field, field
    sim = Simulation.from_scene(tricircle, SolverSettings(rtol=1e-8))
    with pytest.raises(SceneError) as exc:
        sim.ramp(progress="x")  # raised after the first step
    assert exc.value.field == "progress"
