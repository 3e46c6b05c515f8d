"""The fast ``Φ̂–Q̂`` curves (Newton with exact derivatives, interpolated first guesses, limit points as roots
of the exact ``dΦ̂/dλ0`` and ``dQ̂/dλ0``) give what the slow ones gave, checked independently:

- every state carries the pressure when it is shot again from scratch;
- every limit point is where an independent root search (scipy's ``brentq`` on the derivative along the
  curve, with the voltage at each pole stretch found by a second ``brentq`` on freshly shot states) puts it;
- the hard cases keep their structure and their numbers: the spiral at ``p̂ = 1.2`` (eleven turning points),
  the late start at ``p̂ = 1.5``, the late start and early stop at ``p̂ = 1.7`` (neo-Hookean), a
  prestretched membrane; the reference numbers are those of the former regula-falsi implementation at
  ``rtol = 1e-12`` (Chebyshev extremum search), which the new one matches to ``1e-8`` or better.

No timings are asserted here (the machine is shared); ``benchmarks/`` and the report measure them.
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import bounded
from scipy.optimize import brentq

from coexist.curves import voltage_at_pressure, voltage_charge_curve
from coexist.model import build_model
from coexist.settings import SolverSettings
from coexist.shooting import NO_VOLTAGE, OK, REASONS, reason_tag, solve_states

SETTINGS = SolverSettings()
GRID = np.linspace(1.01, 4.0, 200)
QUANTITIES = ("p_hat", "v_hat", "q_hat", "psi_hat", "apex_height", "max_field", "min_tension")


@pytest.fixture(scope="module")
def gent():
    return build_model("gent", 97.0)


@pytest.fixture(scope="module")
def neo():
    return build_model("neo-hookean")


@pytest.fixture(scope="module")
def prestretched():
    return build_model("gent", 97.0, prestretch=2.0)


def _grid(model):
    return np.linspace(1.01 * model.prestretch, max(4.0, 1.5 * model.prestretch), 200)


@pytest.fixture(scope="module")
def curves(gent, neo, prestretched):
    """The curves of the cases, each traced once (on 200 pole stretches, default settings)."""
    models = {"gent": gent, "neo": neo, "prestretched": prestretched}
    cases = [("gent", 1.2), ("gent", 1.5), ("gent", 1.7), ("neo", 1.2), ("neo", 1.7), ("prestretched", 0.5)]
    return {
        (name, p): (models[name], bounded(voltage_charge_curve, models[name], p, _grid(models[name]), SETTINGS))
        for name, p in cases
    }


CASES = ["gent-1.2", "gent-1.5", "gent-1.7", "neo-1.2", "neo-1.7", "prestretched-0.5"]


def _case(curves, case):
    name, p = case.rsplit("-", 1)
    return curves[(name, float(p))]


# --------------------------------------------------------------------------------------------- states


@pytest.mark.parametrize("case", CASES)
def test_every_state_carries_the_pressure_when_shot_again(curves, case):
    """|p̂(λ0, Φ̂) − p̂| ≤ 10 residual_tol p̂ for every state of the curve, shot again from scratch (without
    derivatives, in one batch) at its pole stretch and voltage; the curve's own p̂ meets inner_ftol."""
    model, c = _case(curves, case)
    p = c.fixed
    fresh = solve_states(model, c.pole_stretch, c.phi_hat, SETTINGS).require_ok()
    assert np.all(np.abs(fresh.p_hat - p) <= 10 * SETTINGS.residual_tol * p)
    # the states were shot with and without derivatives, which take different steps (~1e-11 apart)
    assert np.all(np.abs(c.p_hat - p) <= 1e3 * SETTINGS.inner_ftol * p)
    assert np.all(np.diff(c.pole_stretch) > 0) and np.all(c.phi_hat > 0)
    for name in QUANTITIES:
        assert np.all(np.isfinite(getattr(c.states, name)))


@pytest.mark.parametrize("case", ["gent-1.2", "neo-1.7", "prestretched-0.5"])
def test_the_curve_and_voltage_at_pressure_agree(curves, case):
    """The curve's grid solve (interpolated guesses, chord steps) and :func:`voltage_at_pressure` (Newton from
    the regula falsi point) accept the same pole stretches and find the same voltages, to the solver
    tolerance (expressed as a pressure: ``|∂p̂/∂Φ̂| ΔΦ̂ ≤ 1e-9 p̂``)."""
    model, c = _case(curves, case)
    grid = _grid(model)
    s = bounded(voltage_at_pressure, model, grid, c.fixed, SETTINGS)
    run = np.flatnonzero(np.isin(grid, c.pole_stretch))
    assert np.all(s.ok[run])
    slope = np.abs(s.derivatives.dp_dphi[run])
    assert np.all(slope * np.abs(s.phi_hat[run] - c.phi_hat) <= 1e-9 * c.fixed)
    # just outside the run nothing is accepted (the run is the first contiguous one)
    for i in (run[0] - 1, run[-1] + 1):
        if 0 <= i < grid.size:
            assert not s.ok[i]


def test_voltage_at_pressure_flags(gent):
    """Statuses and NaN as documented: infeasible pole stretches (p̂(λ0, 0) < p̂) are NO_VOLTAGE; the ones
    beyond the end of the p̂ = 1.2 spiral carry no voltage either (the pressure stays above p̂ up to the
    pole-wrinkling voltage, checked by sampling); the states found carry derivatives."""
    l0 = np.array([1.1, 2.0, 3.0, 3.3, 3.6])
    s = bounded(voltage_at_pressure, gent, l0, 1.2, SETTINGS)
    assert set(np.unique(s.status).tolist()) <= set(REASONS)
    assert s.status[0] == NO_VOLTAGE  # p̂(1.1, 0) ≈ 0.53 < 1.2
    assert s.ok[1] and s.ok[2] and not s.ok[3] and not s.ok[4]
    assert all(reason_tag(code) == "no_equilibrium" for code in s.status[3:])
    for name in QUANTITIES:
        assert np.all(np.isfinite(getattr(s, name)[s.ok])) and np.all(np.isnan(getattr(s, name)[~s.ok]))
    assert np.all(np.isfinite(s.derivatives.dp_dphi[s.ok])) and np.all(np.isnan(s.derivatives.dp_dphi[~s.ok]))
    np.testing.assert_allclose(s.p_hat[s.ok], 1.2, rtol=SETTINGS.inner_ftol)
    # no voltage reaches 1.2 at λ0 = 3.3: sample the voltages up to where the states stop
    phi = np.linspace(0.0, 0.4, 400)
    sample = solve_states(gent, np.full(phi.size, 3.3), phi, SETTINGS)
    assert sample.ok[:100].all() and np.nanmin(np.where(sample.ok, sample.p_hat, np.nan)) > 1.2
    # a search cut short (one step) accepts nothing it has not converged
    few = bounded(voltage_at_pressure, gent, l0, 1.2, SETTINGS, iterations=1)
    assert np.all(few.status[few.status != OK] >= 10) and np.all(np.abs(few.p_hat[few.ok] - 1.2) <= 1.2e-13)


# ------------------------------------------------------------------------------------ limit points


def _voltage_at(model, l0, p_hat):
    """Φ̂ with p̂(λ0, Φ̂) = p̂ by brentq on freshly shot single states (independent of the library's search)."""

    def f(phi):
        s = solve_states(model, [l0], [phi], SETTINGS)
        return s.p_hat[0] - p_hat if s.ok[0] else -1.0  # a failed state: beyond the root

    hi = 0.05
    while f(hi) > 0:
        hi += 0.05
    return brentq(f, 0.0, hi, xtol=1e-16, rtol=4 * np.finfo(float).eps)


def _along_curve(model, l0, p_hat, kind):
    """dΦ̂/dλ0 (voltage extrema) or dQ̂/dλ0 (charge extrema) along the curve at ``l0``, from a fresh state
    with derivatives at the independently found voltage; and that state."""
    phi = _voltage_at(model, l0, p_hat)
    s = solve_states(model, [l0], [phi], SETTINGS, derivatives=True).require_ok()
    d = s.derivatives
    dphi = -d.dp_dl0[0] / d.dp_dphi[0]
    return (dphi if kind.startswith("voltage") else d.dq_dl0[0] + d.dq_dphi[0] * dphi), s


@pytest.mark.parametrize(
    "case, which",
    [("gent-1.5", 0), ("gent-1.2", 0), ("gent-1.2", 3), ("gent-1.2", 8), ("neo-1.7", 1), ("prestretched-0.5", 1)],
)
def test_limit_points_agree_with_an_independent_root_search(curves, case, which):
    """The limit point is the root of dΦ̂/dλ0 (or dQ̂/dλ0) along the curve found by scipy's brentq in
    ``λ0 ± 4e-3``, each evaluation a fresh state at a voltage found by brentq: λ0 to 1e-8 (relative; the
    extrema in the spiral are very flat, the location is then set by the derivatives' noise), Φ̂ and Q̂ to
    1e-9; and it is an extremum of the shot voltage (or charge) at ``λ0 ± 1e-3``."""
    model, c = _case(curves, case)
    lp = c.limit_points[which]
    p = c.fixed
    h = 4e-3
    g = lambda x: _along_curve(model, x, p, lp.kind)[0]  # noqa: E731
    root = brentq(g, lp.pole_stretch - h, lp.pole_stretch + h, xtol=1e-13, rtol=4 * np.finfo(float).eps)
    _, at = _along_curve(model, root, p, lp.kind)
    assert lp.pole_stretch == pytest.approx(root, rel=1e-8)
    assert lp.phi_hat == pytest.approx(at.phi_hat[0], rel=1e-9)
    assert lp.q_hat == pytest.approx(at.q_hat[0], rel=1e-9)
    assert lp.p_hat == pytest.approx(p, rel=1e-12)
    attr = "phi_hat" if lp.kind.startswith("voltage") else "q_hat"
    sign = 1.0 if lp.kind.endswith("max") else -1.0
    for x in (lp.pole_stretch - 1e-3, lp.pole_stretch + 1e-3):
        phi = _voltage_at(model, x, p)
        near = solve_states(model, [x], [phi], SETTINGS).require_ok()
        assert sign * (getattr(lp, attr) - getattr(near, attr)[0]) > 0


# ------------------------------------------------------------------------------------- the cases

#: (kind, λ0, Φ̂, Q̂) of the former implementation at rtol = 1e-12
REFERENCE = {
    ("gent", 1.5): [("voltage_max", 1.9254069462677805, 0.27096944436412074, 3.921845496848032)],
    ("gent", 1.2): [
        ("voltage_max", 1.7485162275520296, 0.3631141434862991, 4.061619626747771),
        ("charge_max", 2.6079880593992177, 0.33892010781586973, 5.4387903453693465),
        ("voltage_min", 2.723389335077815, 0.33833839544028255, 5.417273666679988),
        ("charge_min", 3.045527851303508, 0.3399076687527135, 5.32374632039193),
        ("voltage_max", 3.088621437225263, 0.33993991021962083, 5.324879744025582),
        ("charge_max", 3.2024342174549583, 0.3398700611782912, 5.329104869945297),
        ("voltage_min", 3.215673887780356, 0.33986870315230183, 5.329057333358646),
        ("charge_min", 3.248534804283565, 0.3398715367668826, 5.3288844202714465),
        ("voltage_max", 3.2522332593737953, 0.33987158999208106, 5.328886278408712),
        # both in the last grid interval (3.2487..3.2638), which the former implementation did not search; these
        # from it at rtol 1e-12 on linspace(3.2, 3.27, 1000), where they are discrete extrema of the grid
        ("charge_max", 3.261302691619109, 0.3398714806978476, 5.328892966528534),
        ("voltage_min", 3.262310580101681, 0.3398714786656854, 5.328892895635453),
    ],
    ("neo", 1.7): [
        ("voltage_max", 2.0255631685771056, 0.16835769072925064, 2.823583609747974),
        ("charge_max", 3.179861277346805, 0.09899208205006038, 4.6632165860741965),
    ],
    ("prestretched", 0.5): [
        ("voltage_max", 2.828303349177606, 0.28485379030804586, 24.610922297416273),
        ("charge_max", 3.9368438439246307, 0.2748257967798504, 29.995114462320743),
    ],
}


@pytest.mark.parametrize("key", list(REFERENCE), ids=lambda k: f"{k[0]}-{k[1]}")
def test_limit_points_match_the_reference(curves, key):
    """Same kinds in the same order, λ0 to 1e-7 (the former search located the flat spiral extrema only to
    ~3e-7 at rtol 1e-10; at 1e-12 it agrees with the new one to 3e-9), Φ̂ and Q̂ to 1e-9."""
    _, c = curves[key]
    ref = REFERENCE[key]
    assert [lp.kind for lp in c.limit_points] == [r[0] for r in ref]
    for lp, (_, l0, phi, q) in zip(c.limit_points, ref):
        assert lp.pole_stretch == pytest.approx(l0, rel=1e-7)
        assert lp.phi_hat == pytest.approx(phi, rel=1e-9)
        assert lp.q_hat == pytest.approx(q, rel=1e-9)


def test_spiral_at_low_pressure(curves):
    """p̂ = 1.2 (Gent, Jlim 97): starts late (no voltage reaches 1.2 below λ0 ≈ 1.27), stops early (none
    beyond ≈ 3.26), eleven turning points alternating voltage and charge (the last two in the last grid
    interval), the voltage monotone between the
    voltage extrema and the charge between the charge extrema; it shares its first valid run with the
    former implementation (134 states from 1.26543)."""
    _, c = curves[("gent", 1.2)]
    assert c.starts_because.startswith("no_equilibrium") and c.stopped_because.startswith("no_equilibrium")
    assert c.pole_stretch.size == 134 and c.pole_stretch[0] == pytest.approx(1.265427135678392, abs=1e-12)
    kinds = [lp.kind for lp in c.limit_points]
    assert kinds[0::2] == ["voltage_max", "voltage_min", "voltage_max", "voltage_min", "voltage_max", "voltage_min"]
    assert kinds[1::2] == ["charge_max", "charge_min", "charge_max", "charge_min", "charge_max"]
    for attr, prefix in (("phi_hat", "voltage"), ("q_hat", "charge")):
        cuts = [lp.pole_stretch for lp in c.limit_points if lp.kind.startswith(prefix)]
        pieces = np.split(np.arange(c.pole_stretch.size), np.searchsorted(c.pole_stretch, cuts))
        for piece in pieces:
            d = np.diff(getattr(c, attr)[piece])
            assert np.all(d > 0) or np.all(d < 0) or d.size == 0


def test_late_start_and_early_stop(curves):
    """p̂ = 1.7 (neo-Hookean): the curve starts where the zero-voltage pressure first exceeds 1.7 and stops
    where it falls below it again; both ends are flagged ``no_equilibrium`` at the pole stretches of the
    former implementation."""
    model, c = curves[("neo", 1.7)]
    assert c.pole_stretch[0] == pytest.approx(1.5659296482412062, abs=1e-12)
    assert c.pole_stretch[-1] == pytest.approx(3.78964824120603, abs=1e-12)
    assert "no voltage" in c.starts_because and c.stopped_because.startswith("no_equilibrium")
    grid = _grid(model)
    zero = solve_states(model, grid, 0.0, SETTINGS)
    i0, i1 = np.searchsorted(grid, c.pole_stretch[[0, -1]])
    assert zero.p_hat[i0 - 1] < 1.7 <= zero.p_hat[i0] and zero.p_hat[i1] >= 1.7 > zero.p_hat[i1 + 1]


def test_default_grid_and_prestretch(prestretched):
    """The default grid (charge_curve_points from 1.01 λpre) of a prestretched membrane: the states hold the
    pressure; a pressure no voltage reaches raises ModelRangeError naming it; a grid that runs past the
    locking stretch finds the stiffened branch."""
    from coexist.errors import ModelRangeError

    c = bounded(voltage_charge_curve, prestretched, 0.5)
    assert c.pole_stretch[0] > 2.0 and c.pole_stretch[-1] <= 4.0
    np.testing.assert_allclose(c.p_hat, 0.5, rtol=1e-12)
    with pytest.raises(ModelRangeError, match="no voltage"):
        bounded(voltage_charge_curve, prestretched, 1.5, np.linspace(2.02, 4.0, 50))
    # up to 8, past the Gent locking stretch (the pole tension is not even defined there): the stiffening
    # membrane carries 1.5 again between λ0 ≈ 5.1 and 6.3
    far = bounded(voltage_charge_curve, prestretched, 1.5, GRID * 2.0)
    assert 5.0 < far.pole_stretch[0] < far.pole_stretch[-1] < 6.5
    assert "no voltage" in far.starts_because and "no voltage" in far.stopped_because
    np.testing.assert_allclose(far.p_hat, 1.5, rtol=1e-12)


# ------------------------------------------------------------------- zero-voltage states where needed


def test_zero_voltage_plan_shoots_only_what_decides_the_run():
    """Given the feasibility of the coarse pole stretches (every 8th), the fine ones shot at zero voltage are
    those before the first feasible coarse one (an isolated feasible stretch there would be the curve) and
    those of the first interval after it that ends infeasible (where the curve ends); beyond that end none
    matters. Between two feasible coarse ones nothing is shot."""
    from types import SimpleNamespace

    from coexist.curves import _zero_voltage_plan

    coarse = np.arange(0, 57, 8)  # 0, 8, ..., 56
    fine = lambda a, b: list(range(a + 1, b))  # noqa: E731
    roots = SimpleNamespace(l0=np.linspace(1.01, 4.0, 57), feasible=np.zeros(57, dtype=bool))
    roots.feasible[[16, 24, 48]] = True  # feasible at 16 and 24, not at 32 or 40, again at 48
    rows, beyond = _zero_voltage_plan(roots, coarse)
    assert rows.tolist() == fine(0, 8) + fine(8, 16) + fine(24, 32) and beyond == 33
    roots.feasible[:] = False
    rows, beyond = _zero_voltage_plan(roots, coarse)
    assert rows.tolist() == sorted(set(range(57)) - set(coarse.tolist())) and beyond == 57
    roots.feasible[[40, 48, 56]] = True  # feasible to the end of the grid
    rows, beyond = _zero_voltage_plan(roots, coarse)
    assert rows.tolist() == sorted(set(range(40)) - set(coarse.tolist())) and beyond == 57


def test_the_curve_shoots_few_zero_voltage_states(gent, monkeypatch):
    """The p̂ = 1.5 curve on 200 pole stretches shoots 54 zero-voltage states (26 coarse, 28 before and at its
    start), not 200, and still starts where every zero-voltage state says it can (the first pole stretch
    with p̂(λ0, 0) ≥ 1.5, checked on all 200); at p̂ = 1.2 on a grid to λ0 = 8, where the Gent membrane
    carries the pressure again past the stiffening (λ0 ≈ 5.1 to 6.2), the curve is the first valid run
    and starts and ends as voltage_at_pressure (every pole stretch solved from scratch) says."""
    import coexist.curves as curves

    shot = []
    real = curves.solve_states

    def counting(model, l0, phi, *args, **kwargs):
        if np.ndim(phi) == 0 and float(phi) == 0.0:
            shot.append(np.size(l0))
        return real(model, l0, phi, *args, **kwargs)

    # 54 through the compiled attempt function; 65 where it is not in use (COEXIST_COMPILE=0, no compiler, or a fresh
    # process before its COMPILE_AFTER-th use: the full suite's worker that ran this first): numpy's stepper rounds
    # otherwise, and 11 fine states leave the chord steps for the Newton iteration, shot at zero voltage first
    # (measured, sixth session). One curve first, so that the counted one runs as a process's later curves do
    bounded(voltage_charge_curve, gent, 1.5, GRID, SETTINGS)
    monkeypatch.setattr(curves, "solve_states", counting)
    c = bounded(voltage_charge_curve, gent, 1.5, GRID, SETTINGS)
    monkeypatch.undo()
    from coexist.shooting import _integrators

    fast = bool((_integrators(gent)._casadi.get(("attempts", "radius")) or {}).get("fast"))
    assert sum(shot) <= (60 if fast else 70), (sum(shot), fast)
    zero = solve_states(gent, GRID, 0.0, SETTINGS)
    first = int(np.argmax(zero.p_hat >= 1.5))
    assert c.pole_stretch[0] == GRID[first] and "no voltage" in c.starts_because
    grid = np.linspace(1.01, 8.0, 200)
    far = bounded(voltage_charge_curve, gent, 1.2, grid, SETTINGS)
    ref = bounded(voltage_at_pressure, gent, grid, 1.2, SETTINGS)
    i0, i1 = np.searchsorted(grid, far.pole_stretch[[0, -1]])
    assert np.all(ref.ok[i0 : i1 + 1]) and not ref.ok[i0 - 1] and not ref.ok[i1 + 1]
    assert ref.ok[i1 + 2 :].any()  # a second stretch carries 1.2: not part of the curve
    slope = np.abs(ref.derivatives.dp_dphi[i0 : i1 + 1])
    assert np.all(slope * np.abs(far.phi_hat - ref.phi_hat[i0 : i1 + 1]) <= 1e-9 * 1.2)
