"""Limit points that the grid values alone do not show (found in review, helper-60): an extremum in the first or
last interval of a curve's valid run, and a maximum and a minimum within one interval. The curves now sample the
slope along the grid by the secants and, at both ends and around sharp bends, by the exact slopes of the
variational equations (``curves._grid_extrema``). Every limit point found is compared with the same one
located on a grid where it is an ordinary interior discrete extremum (the detection the former code had)."""

import json

import numpy as np
import pytest
from click.testing import CliRunner

from coexist.cli.main import cli
from coexist.curves import pressure_volume_curve, voltage_charge_curve
from coexist.model import build_model
from coexist.settings import SolverSettings

#: λ0 to the limit-point tolerance (1e-9 relative) of either location, with room for both; the extremal value to
#: the states' tolerance (rtol 1e-10, ×10); the other quantities read there through their slopes (|dV̂/dλ0| ≈ 4)
LAMBDA_TOL = 3e-9
VALUE_TOL = 1e-9
READ_TOL = 2e-8
#: the quantity each kind is an extremum of
EXTREMAL = {"pressure": "p_hat", "volume": "v_hat", "voltage": "phi_hat", "charge": "q_hat"}


def _kinds(curve, prefix=""):
    return [(lp.kind, lp) for lp in curve.limit_points if lp.kind.startswith(prefix)]


def _same(found, reference):
    assert found.kind == reference.kind
    assert found.pole_stretch == pytest.approx(reference.pole_stretch, rel=LAMBDA_TOL)
    extremal = EXTREMAL[found.kind.split("_")[0]]
    for name in ("p_hat", "v_hat", "phi_hat", "q_hat"):
        tol = VALUE_TOL if name == extremal else READ_TOL
        assert getattr(found, name) == pytest.approx(getattr(reference, name), rel=tol, abs=1e-12), name


@pytest.fixture(scope="module")
def neo():
    return build_model("neo-hookean", voltage=True)


def test_pressure_minimum_in_the_last_interval(neo):
    """``coexist curves --phi-hat 0.2 --pole-stretch 1.01,3.775``: the pressure minimum at λ0 ≈ 3.7713 lies in
    the last of 200 intervals (the grid values fall to the end); it was not reported."""
    ref = dict(_kinds(pressure_volume_curve(neo, 0.2, np.linspace(1.01, 4.0, 200)), "pressure"))
    c = pressure_volume_curve(neo, 0.2, np.linspace(1.01, 3.775, 200))
    assert np.all(np.diff(c.p_hat[-5:]) < 0)  # nothing to see in the values
    found = dict(_kinds(c, "pressure"))
    assert set(found) == set(ref) == {"pressure_max", "pressure_min"}
    for kind in ref:
        _same(found[kind], ref[kind])
    assert c.pole_stretch[-2] < found["pressure_min"].pole_stretch < c.pole_stretch[-1]


def test_pressure_maximum_in_the_first_interval(neo):
    """A grid whose first interval holds the pressure maximum (λ0 ≈ 2.055 at Φ̂ = 0.15): the values fall from the
    first node on."""
    ref = dict(_kinds(pressure_volume_curve(neo, 0.15, np.linspace(1.01, 4.0, 200)), "pressure_max"))
    grid = np.linspace(2.05, 3.5, 100)
    c = pressure_volume_curve(neo, 0.15, grid)
    assert np.all(np.diff(c.p_hat[:5]) < 0)
    (found,) = [lp for kind, lp in _kinds(c, "pressure_max")]
    _same(found, ref["pressure_max"])
    assert grid[0] < found.pole_stretch < grid[1]


@pytest.mark.parametrize("start", [1.15, 1.25, 1.05])
def test_pressure_maximum_and_minimum_in_one_interval(start):
    """Gent Jlim 72 at zero voltage: the pressure maximum (λ0 ≈ 2.823) and minimum (≈ 3.217) lie 0.39 apart, so a
    grid of step 0.45 or 0.6 puts both in one interval, or one on either side of a node, and its values rise
    through them; neither was reported."""
    model = build_model("gent", jlim=72.0, voltage=False)
    ref = dict(_kinds(pressure_volume_curve(model, 0.0, np.linspace(1.01, 6.0, 2000)), "pressure"))
    assert set(ref) == {"pressure_max", "pressure_min"}
    for step in (0.45, 0.6):
        grid = np.arange(start, 5.0, step)
        c = pressure_volume_curve(model, 0.0, grid)
        found = dict(_kinds(c, "pressure"))
        assert set(found) == set(ref), (start, step)
        for kind in ref:
            _same(found[kind], ref[kind])


def test_voltage_maximum_in_the_first_interval():
    """A ``Φ̂–Q̂`` curve (Gent Jlim 97, p̂ = 1.5) on a grid whose first interval holds its voltage maximum."""
    model = build_model("gent", jlim=97.0, voltage=True)
    settings = SolverSettings()
    ref = dict(_kinds(voltage_charge_curve(model, 1.5, np.linspace(1.01, 4.0, 200), settings), "voltage_max"))
    at = ref["voltage_max"].pole_stretch
    grid = np.linspace(at - 0.004, at + 1.0, 80)
    c = voltage_charge_curve(model, 1.5, grid, settings)
    assert c.pole_stretch[0] == grid[0] and np.all(np.diff(c.phi_hat[:5]) < 0)
    (found,) = [lp for kind, lp in _kinds(c, "voltage_max")]
    _same(found, ref["voltage_max"])


def test_a_monotone_stretch_has_none(neo):
    """No limit point where there is none: the zero-voltage curve past its maximum, and a grid that stops just
    short of it (the exact slopes at the ends agree with the secants)."""
    assert pressure_volume_curve(neo, 0.0, np.linspace(2.5, 4.0, 60)).limit_points == []
    c = pressure_volume_curve(neo, 0.0, np.linspace(1.01, 4.0, 200))
    (lp,) = [lp for kind, lp in _kinds(c, "pressure_max")]
    assert pressure_volume_curve(neo, 0.0, np.linspace(1.01, lp.pole_stretch * (1 - 1e-4), 50)).limit_points == []


def test_command_line_reports_the_minimum_in_the_last_interval():
    """The review's reproduction, as a user runs it."""
    r = CliRunner().invoke(
        cli, ["curves", "--phi-hat", "0.2", "--p-hat", "none", "--pole-stretch", "1.01,3.775", "--json"]
    )
    assert r.exit_code == 0, r.output
    (curve,) = json.loads(r.stdout)["curves"]
    kinds = [lp["kind"] for lp in curve["limit_points"]]
    assert "pressure_min" in kinds
    (lp,) = [lp for lp in curve["limit_points"] if lp["kind"] == "pressure_min"]
    # the root of the exact slope, as at rtol 1e-13 (3.77130544581; the extremum of interpolated values at rtol
    # 1e-10 was 1.3e-8 off, printed as 3.77130543)
    assert lp["pole_stretch"] == pytest.approx(3.7713054458, abs=1e-9)


def test_extremum_in_the_last_interval_next_to_another_at_the_end():
    """Found in review (helper-61): a run ending within 1e-8..1e-7 of one extremum has a tiny exact end slope, which
    was taken for noise, and the extremum inside the last interval was lost."""
    m = build_model("gent", jlim=97.0, voltage=True)
    c = voltage_charge_curve(m, 1.2, np.linspace(1.3, 3.215673877728086, 9))  # ends 1e-8 before a voltage minimum
    assert c.pole_stretch[-2] < 3.0886 < c.pole_stretch[-1]
    assert [lp.pole_stretch for lp in c.limit_points if lp.kind == "voltage_max"][-1] == pytest.approx(
        3.08862144, abs=1e-8
    )
    c = voltage_charge_curve(m, 1.2, np.linspace(1.13406585611829, 3.2613024652656533, 6))  # 2.3e-7 before a max
    assert any(abs(lp.pole_stretch - 3.04552785) < 1e-8 for lp in c.limit_points if lp.kind == "charge_min")
    g = build_model("gent", jlim=72.0, voltage=False)
    c = pressure_volume_curve(g, 0.0, np.linspace(1.15, 2.8231635697 + 1e-7, 9))
    assert [lp.kind for lp in c.limit_points] == ["pressure_max"]
    assert c.limit_points[0].pole_stretch == pytest.approx(2.8231635697, rel=LAMBDA_TOL)


def test_location_is_the_root_of_the_exact_slope_on_fine_grids():
    """Found in review (helper-61): on fine grids the extremum of interpolated values in a one-interval bracket was
    off by up to 1.8e-7 in λ0 (the values' noise over a flat extremum). The limit point is the root of the exact
    slope ``dp̂/dλ0`` (variational equations), here located independently by scipy's ``brentq``."""
    from scipy.optimize import brentq

    from coexist.shooting import solve_states

    model = build_model("gent", jlim=72.0, voltage=False)
    settings = SolverSettings()

    def slope(x):
        return float(solve_states(model, np.array([x]), 0.0, settings, derivatives=True).derivatives.dp_dl0[0])

    roots = {"pressure_max": brentq(slope, 2.7, 2.9, xtol=1e-13), "pressure_min": brentq(slope, 3.1, 3.3, xtol=1e-13)}
    for n in (500, 1000, 4000):
        found = dict(_kinds(pressure_volume_curve(model, 0.0, np.linspace(1.01, 4.9, n), settings), "pressure"))
        assert set(found) == set(roots)
        for kind, root in roots.items():
            assert found[kind].pole_stretch == pytest.approx(root, rel=2e-9), (n, kind)


def test_no_limit_points_from_the_noise_of_a_flat_stretch():
    """Found in review (helper-61): zoomed into the centre of a ``Φ̂–Q̂`` spiral (neo-Hookean, p̂ = 1, 2000 points on
    λ0 ∈ [2.495, 2.5014], where Φ̂ varies by 1.4e-8 and Q̂ by 1.2e-8 relative), the curve reported 98 limit points,
    most of them pairs whose values differ by 1e-12 relative: the noise of the states (rtol 1e-10). Extrema whose
    swing is below rtol are dropped in pairs (``curves._resolved``); what is left are those of the same window at
    rtol 1e-12, in order. Their locations are ill-conditioned here (the curve is flat to 1e-8): 1e-4 is asked."""
    m = build_model("neo-hookean", voltage=True)
    ref = voltage_charge_curve(m, 1.0, np.linspace(2.495, 2.5014, 200), SolverSettings(rtol=1e-12)).limit_points
    assert [lp.kind for lp in ref] == ["charge_max", "voltage_min", "charge_min", "voltage_max"]
    c = voltage_charge_curve(m, 1.0, np.linspace(2.495, 2.5014, 2000))
    kinds = [lp.kind for lp in c.limit_points]
    assert 3 <= len(kinds) <= 4 and kinds == [lp.kind for lp in ref][: len(kinds)]
    for lp, r in zip(c.limit_points, ref):
        assert abs(lp.pole_stretch - r.pole_stretch) < 1e-4
        extremal = EXTREMAL[lp.kind.split("_")[0]]  # its value to rtol; the other, read at the location, to 1e-8
        for name in ("phi_hat", "q_hat"):
            assert getattr(lp, name) == pytest.approx(getattr(r, name), rel=1e-10 if name == extremal else 1e-8)


@pytest.mark.parametrize("offset", [0.5, 1.5, 2.5])
def test_a_maximum_near_the_start_of_a_fine_grid_at_draft_accuracy(offset):
    """The noise filter first also dropped an extremum within rtol of the curve's end value: at rtol 1e-6 a grid of
    step 2e-4 starting 1.5 or 2.5 steps before the neo-Hookean pressure maximum lost it."""
    m = build_model("neo-hookean", voltage=False)
    x, h = 2.1959445440, 2e-4
    c = pressure_volume_curve(m, 0.0, np.arange(x - offset * h, x + 0.2, h), SolverSettings(rtol=1e-6))
    assert [lp.kind for lp in c.limit_points] == ["pressure_max"]
    assert c.limit_points[0].pole_stretch == pytest.approx(x, abs=1e-6)


def test_draft_accuracy_keeps_real_pairs_of_extrema():
    """Found in review (helper-63): the noise filter dropped pairs whose swing was below rtol, but at rtol 1e-6 the
    states are good to about 1e-8 relative: the p̂ = 1.2 spiral lost two turning points at draft accuracy, Gent Jlim
    70.73 lost its nearly merged pressure maximum and minimum, and the snap-through at Jlim 70.738 was reported as
    no snap-through. Pairs confirmed by exact slopes (at their brackets' ends, or between them in one interval)
    are kept."""
    from coexist.simulation import snap_through, stretch_range_end

    gent = build_model("gent", jlim=97.0, voltage=True)
    grid = np.linspace(1.01, 4.0, 200)
    default = [lp.kind for lp in voltage_charge_curve(gent, 1.2, grid).limit_points]
    draft = [lp.kind for lp in voltage_charge_curve(gent, 1.2, grid, SolverSettings(rtol=1e-6)).limit_points]
    assert draft == default and len(default) == 11

    near = build_model("gent", jlim=70.73, voltage=False)
    kinds = lambda s: [lp.kind for lp in pressure_volume_curve(near, 0.0, np.linspace(1.01, 7.0, 400), s).limit_points]  # noqa: E731
    pressure = [k for k in kinds(SolverSettings(rtol=1e-6)) if k.startswith("pressure")]
    assert (
        pressure == [k for k in kinds(SolverSettings()) if k.startswith("pressure")] == ["pressure_max", "pressure_min"]
    )

    edge = build_model("gent", jlim=70.738, voltage=False)
    for rtol in (1e-6, 1e-10):
        s = SolverSettings(rtol=rtol)
        snap = snap_through(edge, s, stretch_range_end(edge.elasticity, 1.0, s))
        assert snap.maximum and snap.p_hat == pytest.approx(2.0251987, rel=1e-6), rtol


def test_a_pole_radius_allowed_at_the_users_tolerance_survives_a_tighter_one():
    """Found in review (helper-63): events are located again at rtol/100, where an explicit pole_radius of 1e-3 (allowed
    at rtol 1e-11, up to 5.6e-3) exceeded rtol^(1/4) and the ramp raised a SceneError."""
    s = SolverSettings(rtol=1e-11, pole_radius=1e-3)
    tight = s.with_rtol(1e-13)
    assert tight.rtol == 1e-13 and tight.pole_radius == pytest.approx(1e-13**0.25)
    assert s.with_rtol(1e-8).pole_radius == 1e-3


def test_patterned_curve_finds_the_extremum_in_its_last_interval():
    """The inner-circle scene's zone at Φ̂ = 0.3: its curve ends where the pole wrinkles (λ0 = 3.95492), and the
    last interval of the default grid holds its pressure maximum (λ0 = 3.9444551) and its volume maximum (λ0 =
    3.9546023775, 0.7e-3 before the end). Without exact slopes a patterned curve searched no end interval and
    missed the volume maximum; a fine grid ending at the same place has both inside."""
    from coexist import Simulation, load_scene
    from coexist.patterned import patterned_pressure_volume_curve

    sim = Simulation.from_scene(load_scene("inner-circle"))
    zone, pattern = sim.model.uniform, sim.model.pattern
    curve = patterned_pressure_volume_curve(zone, pattern, 0.3)
    last = curve.states.pole_stretch[-2:]
    found = [lp for lp in curve.limit_points if last[0] < lp.pole_stretch < last[1]]
    assert [lp.kind for lp in found] == ["pressure_max", "volume_max"], curve.limit_points
    fine = patterned_pressure_volume_curve(zone, pattern, 0.3, np.linspace(3.9, last[1], 60))
    for lp in found:
        (ref,) = [r for r in fine.limit_points if r.kind == lp.kind and abs(r.pole_stretch - lp.pole_stretch) < 1e-3]
        assert abs(lp.pole_stretch - ref.pole_stretch) <= lp.errors["pole_stretch"] < 1e-8
        assert abs(lp.v_hat - ref.v_hat) <= lp.errors["v_hat"] and abs(lp.p_hat - ref.p_hat) <= lp.errors["p_hat"]


@pytest.mark.parametrize("points", [30, 100])
def test_a_curve_ends_where_its_states_jump_and_reports_no_limit_point_there(points):
    """A tension-field ring electrode (Gent 97, ring 0.3–0.7, Φ̂ = 0.3) wrinkles over its whole width at once at
    its onset, λ0 = 2.44692: p̂ falls from 1.3387 to 0.5427 and V̂ rises from 4.295 to 13.83 between two states
    1e-5 apart, onto another branch. A pressure minimum had been reported at the jump (its location moving with
    the grid by 3e-3: review, helper-65). The curve now ends before the jump and says why; the states up to it
    and the pressure maximum before it are unchanged."""
    from coexist.patterned import ZonePattern, patterned_pressure_volume_curve

    model = build_model("gent", 97.0, voltage=True, wrinkling="tension-field")
    ring = ZonePattern.ring(0.3, 0.7, 1)
    curve = patterned_pressure_volume_curve(model, ring, 0.3, np.linspace(1.01, 4, points), SolverSettings(rtol=1e-8))
    assert curve.stopped_because.startswith("jump: beyond pole stretch"), curve.stopped_because
    assert curve.states.pole_stretch[-1] < 2.44692 < curve.states.pole_stretch[-1] + 3 * 2.99 / (points - 1)
    assert [lp.kind for lp in curve.limit_points] == ["pressure_max"]
    assert curve.limit_points[0].errors is not None
    # just before the onset the states are continuous: no jump on a fine grid that ends there
    fine = patterned_pressure_volume_curve(model, ring, 0.3, np.linspace(2.40, 2.4469, 40), SolverSettings(rtol=1e-8))
    assert fine.stopped_because is None


def test_smooth_curves_show_no_jump():
    """The jump test (a change ten times what the exact end slopes allow) stays silent on smooth curves: coarse
    grids, steep Gent stiffening near locking, spirals (360 uniform and 96 patterned curves were scanned)."""
    for model, phi in ((build_model("gent", 10.0), 0.0), (build_model("neo-hookean", voltage=True), 0.3)):
        for points in (15, 60):
            curve = pressure_volume_curve(model, phi, np.linspace(1.01, 4, points))
            assert curve.stopped_because is None or not curve.stopped_because.startswith("jump"), curve.stopped_because


def test_a_jump_inside_the_first_interval_starts_the_curve_after_it():
    """A tension-field ring electrode at Φ̂ = 0.4 (Gent 97, ring 0.3–0.7) bulges down (p̂, V̂ < 0) up to λ0 = 1.01133
    and up beyond: p̂ −0.0237 → 0.0238 and V̂ −0.300 → 0.301 within 5e-5 in λ0, where the exact slopes are about ±2.3
    and ±7. On a grid whose first interval holds that jump the end slopes allow the change, and a pressure minimum
    and a volume minimum had been reported at λ0 ≈ 1.0112 (one ± 8e-2, the other "error not measured"). The
    iteration on the exact slope meets the jump between its own states (−2.3 at 1.01091, +2.3 at 1.01139): the curve
    now starts after it and says why; the pressure maximum stays. On a fine grid around it the same jump ends the
    curve (the states before it are the down-bulged branch)."""
    from coexist.patterned import ZonePattern, patterned_pressure_volume_curve

    model = build_model("gent", 97.0, voltage=True, wrinkling="tension-field")
    ring = ZonePattern.ring(0.3, 0.7, 1)
    grid = np.linspace(1.01, 1.9, 60)
    curve = patterned_pressure_volume_curve(model, ring, 0.4, grid)
    assert curve.starts_because.startswith("jump: below pole stretch"), curve.starts_because
    assert curve.states.pole_stretch[0] == grid[1] and np.all(curve.states.v_hat > 0)
    assert [lp.kind for lp in curve.limit_points] == ["pressure_max"]
    assert curve.limit_points[0].pole_stretch == pytest.approx(1.49978689, abs=1e-7)
    fine = patterned_pressure_volume_curve(model, ring, 0.4, np.linspace(1.0105, 1.0125, 41))
    assert fine.stopped_because.startswith("jump: beyond pole stretch")
    assert fine.states.pole_stretch[-1] < 1.01133 < fine.states.pole_stretch[-1] + 5e-5
    assert np.all(fine.states.v_hat < 0) and fine.limit_points == []


@pytest.mark.parametrize("phi, grid", [(0.4, np.linspace(1.01, 1.9, 15)), (0.45, np.linspace(1.01, 1.9, 60))])
def test_a_jump_in_an_interval_without_a_start_for_the_slope_iteration(phi, grid):
    """The same ring on grids whose first interval holds the jump but where the exact-slope iteration has no start
    (its end slope not yet known, or the interval's cubic without an extremum): minima had been reported at
    λ0 ≈ 1.0108 (15 points, Φ̂ = 0.4) and 1.0128 (60 points, Φ̂ = 0.45) where p̂ and V̂ fall steadily on a fine
    grid (review, helper-68). The exact slope is bisected on its sign: it keeps its size (±2.3 in p̂) on both sides
    of λ0 = 1.0113473 (Φ̂ = 0.4), and the curve starts after the jump."""
    from coexist.patterned import ZonePattern, patterned_pressure_volume_curve

    model = build_model("gent", 97.0, voltage=True, wrinkling="tension-field")
    curve = patterned_pressure_volume_curve(model, ZonePattern.ring(0.3, 0.7, 1), phi, grid)
    assert curve.starts_because.startswith("jump: below pole stretch"), curve.starts_because
    assert curve.states.pole_stretch[0] == grid[1] and np.all(curve.states.v_hat > 0)
    assert [lp.kind for lp in curve.limit_points] == ["pressure_max"]


def test_the_slope_bisection_stops_once_it_sees_the_jump(monkeypatch):
    """The bisection of the exact slope across that jump stops once its states have shown the jump in five rounds in a
    row (two of them straddle it closely enough for the change to exceed what their slopes allow: Δp̂ ≈ 0.047 where
    |dp̂/dλ0| ≈ 2.3): it had gone on to its 24th halving, 24 relaxed tension-field states per bracket (3.7 s; the
    whole curve 4.3–4.6 s). The curve is the same: it starts after the jump, with the same pressure maximum."""
    from coexist import curves
    from coexist.patterned import ZonePattern, patterned_pressure_volume_curve

    probes = []
    bisection = curves._slope_sign_bisection

    def counted(states, brackets, slopes, slopes_at, samples, *rest):
        before = [len(s) for s in samples]
        bisection(states, brackets, slopes, slopes_at, samples, *rest)
        probes.append([len(s) - b for s, b in zip(samples, before)])

    monkeypatch.setattr(curves, "_slope_sign_bisection", counted)
    model = build_model("gent", 97.0, voltage=True, wrinkling="tension-field")
    grid = np.linspace(1.01, 4.0, 200)
    curve = patterned_pressure_volume_curve(model, ZonePattern.ring(0.3, 0.7, 1), 0.4, grid)
    assert curve.starts_because.startswith("jump: below pole stretch"), curve.starts_because
    assert curve.states.pole_stretch[0] == grid[1]
    assert [lp.kind for lp in curve.limit_points] == ["pressure_max"]
    assert curve.limit_points[0].pole_stretch == pytest.approx(1.49978689, abs=1e-7)
    bisected = [n for call in probes for n in call]
    assert bisected and max(bisected) <= 8, probes


def test_a_state_that_fails_inside_a_bracket_ends_the_curve_there():
    """A tension-field ring electrode (Gent 97, ring 0.3–0.7) at Φ̂ = 0.47 on 15 points: the states at λ0 = 1.01 and
    1.2236 are valid, those between pull in. Locating the pressure extremum the grid showed there met them, and the
    whole curve had failed (``SolverError: no valid state near a limit point of p_hat``; review, helper-69). The run
    of valid states ends before them now, as on a grid that holds them: on 200 points the curve is the single state
    at 1.01 too, ending in the same pull-in. The command line prints the curve, the note and no limit point."""
    from coexist.patterned import ZonePattern, patterned_pressure_volume_curve

    model = build_model("gent", 97.0, voltage=True, wrinkling="tension-field")
    ring = ZonePattern.ring(0.3, 0.7, 1)
    grid = np.linspace(1.01, 4.0, 15)
    coarse = patterned_pressure_volume_curve(model, ring, 0.47, grid)
    fine = patterned_pressure_volume_curve(model, ring, 0.47, np.linspace(1.01, 4.0, 200))
    for c in (coarse, fine):
        assert c.states.pole_stretch.tolist() == [1.01] and c.limit_points == []
        assert c.stopped_because.startswith("electromechanical_instability: beyond pole stretch 1.01 ")
    at = float(coarse.stopped_because.split("(at ")[1].split(",")[0])
    assert grid[0] < at < grid[1]
    args = ["curves", "--material", "gent", "--jlim", "97", "--wrinkling", "tension-field", "--pattern", "ring"]
    args += ["--inner-fraction", "0.3", "--outer-fraction", "0.7", "--phi-hat", "0.47", "--p-hat", "none"]
    r = CliRunner().invoke(cli, [*args, "--points", "15"])
    assert r.exit_code == 0, r.output
    assert "stops early: electromechanical_instability" in r.output and "none on these curves" in r.output


def test_a_gap_before_the_end_keeps_the_limit_points_before_it():
    """A ring 0.1–0.5 (Gent 97, tension-field) at Φ̂ = 0.45 on 30 points: a state pulls in between the grid states at
    λ0 = 1.42241 and 1.52552 (at 1.45924; it had failed the whole curve). The curve ends at 1.42241, before the end
    on 200 points (1.44573), with the same pressure maximum (λ0 = 1.3598)."""
    from coexist.patterned import ZonePattern, patterned_pressure_volume_curve

    model = build_model("gent", 97.0, voltage=True, wrinkling="tension-field")
    ring = ZonePattern.ring(0.1, 0.5, 1)
    coarse = patterned_pressure_volume_curve(model, ring, 0.45, np.linspace(1.01, 4.0, 30))
    fine = patterned_pressure_volume_curve(model, ring, 0.45, np.linspace(1.01, 4.0, 200))
    assert coarse.stopped_because.startswith("electromechanical_instability: beyond pole stretch 1.42241 (at ")
    assert coarse.states.pole_stretch[-1] <= fine.states.pole_stretch[-1]
    assert [lp.kind for lp in coarse.limit_points] == [lp.kind for lp in fine.limit_points] == ["pressure_max"]
    assert coarse.limit_points[0].pole_stretch == pytest.approx(fine.limit_points[0].pole_stretch, abs=1e-7)
