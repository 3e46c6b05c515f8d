"""Benchmark: the scene pipeline (``Simulation.from_scene(scene).ramp()``), against a scipy baseline.

Every time is wall-clock (``time.perf_counter``) of work done in this process; the machine is shared,
so each timing is the **best** of several runs (the spread is printed), after one untimed warm-up
run that compiles the CasADi attempt function if this machine has none cached yet (~/.cache/coexist).

1. **Default ramp** (built-in scene ``tricircle``: 3 zones, 0 → 5 → 0 kV in 0.02 kV steps, 501
   voltages, 434 of them with a state: above 4.33 kV the bulged zone wrinkles):
   ``Simulation.from_scene(scene).ramp()`` (model build, snap-through, closing state and gas
   included), best of 5. Breakdown, best of 5 each: the same with
   ``SolverSettings(error_estimates=False)``, then ``Simulation.measure_errors`` on that run's transitions
   timed alone (what ``error_estimates`` adds: every transition re-located at ``rtol/100``; too small
   to show as a difference of two whole runs), and ``Simulation.from_scene`` alone.
2. **Baseline** (:class:`ScipyBaseline`), what a skilled scipy user would write for the same run on the
   same exact states (:func:`coexist.shooting.solve_states`, same tolerance ``rtol = 1e-10``):
   ``scipy.optimize.root`` (``hybr``, ``xtol = 1e-13``) on the homogeneous residual
   ``p̂(λ, Φ̂) − p̂_gas(3V̂(λ, Φ̂))`` warm-started from the previous voltage of the grid; the homogeneous
   state's stability from the sign of ``dp̂/dλ`` (5-point central difference, ``h = 1e-3``, one
   vectorised ``solve_states`` call), its loss bisected in the voltage to 1e-9 kV; the jump's target
   (one bulged zone) by ``root`` on ``[p̂(λu) − p̂(λb), p̂(λu) − p̂_gas(2V̂(λu) + V̂(λb))]`` from the fast
   path's landing pole stretches *rounded to one decimal*; that state followed up the grid until
   ``root`` stops converging (the bulged zone wrinkles), that end bisected, the grid above it left
   without a state; on the way down the bulged states of the way up are reused, then it is followed
   down until ``root`` stops converging (its fold in the voltage, where its stability is lost; not
   checked otherwise), bisected; below the fold the homogeneous states of the way up are reused (a
   state already solved at a voltage is never solved again); the equal-free-energy voltage
   (``G = Σ n Ψ̂ + G_gas``) bisected between the grid voltages where the sign of
   ``G_bulged − G_homogeneous`` changes. "Converged" means valid states and a residual ``≤ 1e-12``
   (``xtol = 1e-13`` leaves residuals of a few 1e-13). The baseline's fourth voltage, where the
   bulged zone wrinkles (a bisection on the validity of the states), is compared as well. Its time
   includes its own ``Simulation.from_scene`` (it takes the model and the gas from it, nothing
   else); best of 3 (one run if it took more than 30 s). Its four voltages are printed beside the
   fast path's, and the script fails unless they agree to 1e-6 kV and the baseline has a state at
   the same voltages, in the same configurations, as the fast path.
3. **Cost against the number of zones**: ``count = 3, 10, 100, 1000`` (other keys of ``tricircle``
   unchanged), ``from_scene + ramp`` best of 3 each, and the ratio N = 1000 / N = 3.
4. **Cost and memory against the voltage range and step**: ``stop_kV = 5, 20, 50`` at
   ``step_kV = 0.02`` and ``stop_kV = 5`` at ``step_kV = 0.002``: time best of 3, and the peak of
   Python allocations (``tracemalloc``: Python objects and numpy's buffers, not CasADi's own C++
   memory) in one more, untimed run.
5. ``coexist phase-diagram``'s computation (``coexistence.phase_diagram``, Gent Jlim = 40, 37
   voltages), one run, and ``python -m coexist --help`` start-up (heavy imports are lazy), mean and
   minimum of 5 runs in a subprocess.

Run: ``.venv/bin/python benchmarks/bench_pipeline.py [--json] [--quick]`` (``--json``: the results as
JSON on stdout, progress on stderr; ``--quick``: one timed run per item, to check the script). It takes
about 2.5 minutes (1.5 with ``--quick``).
"""

from __future__ import annotations

import argparse
import json
import platform
import re
import subprocess
import sys
import time
import tracemalloc

import numpy as np
import scipy
from scipy.optimize import root

from coexist.scene import builtin_scene_text, load_scene, parse_scene
from coexist.settings import SolverSettings
from coexist.shooting import solve_states
from coexist.simulation import Simulation

SCENE = "tricircle"
#: the baseline bisects every voltage to this bracket (kV)
BISECT_KV = 1e-9
#: the baseline's voltages must agree with the fast path's to this (kV); the script fails otherwise
AGREE_KV = 1e-6
#: ... except the pull-in end, which the baseline can only bisect on whether its root-finder still converges:
#: near the end the states approach a singular meridian and scipy's root (which asks for a residual at the
#: shooting's own noise level, RESIDUAL_TOL) fails a little before it: 9.2e-6 kV below the end in one run,
#: 4.7e-5 kV in another after the shooting's small batches changed their rounding (the fast path's end moved by
#: 2e-12 kV), while the fast path extrapolates the end from a smooth function of the states (error 2e-8 kV).
#: The baseline's end must lie below the fast path's and within this of it
PULL_IN_AGREE_KV = 1e-4
#: the baseline's root counts as converged when its states are valid and its residual is at most this
RESIDUAL_TOL = 1e-12
#: step of the baseline's 5-point central difference of dp̂/dλ
DIFF_STEP = 1e-3
#: the baseline is run once if it takes longer than this, else best of 3
BASELINE_SINGLE_RUN_S = 30.0
ZONE_COUNTS = (3, 10, 100, 1000)
VOLTAGE_VARIANTS = ((5, 0.02), (20, 0.02), (50, 0.02), (5, 0.002))


def log(msg: str) -> None:
    print(msg, file=sys.stderr, flush=True)


def scene_variant(**keys):
    """``tricircle`` with some ``key = value`` lines of its TOML text replaced (each must occur once)."""
    text = builtin_scene_text(SCENE)
    for key, value in keys.items():
        text, n = re.subn(rf"^{key}\s*=.*$", f"{key} = {value}", text, flags=re.M)
        if n != 1:
            raise RuntimeError(f"{key!r} occurs {n} times in the scene text")
    return parse_scene(text)


def compute(scene):
    """The timed unit: the whole compute of a ramp, from the scene."""
    return Simulation.from_scene(scene).ramp()


def best_of(fn, repeats: int):
    """``(best, times, last result)`` of ``repeats`` timed calls of ``fn``."""
    times, out = [], None
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return min(times), times, out


def spread(times) -> dict:
    return {"best": float(min(times)), "worst": float(max(times)), "runs": len(times)}


def transition_voltages(report) -> dict:
    """The default scene's four voltages (kV) from a fast-path report."""
    res = report.result
    kv = report.voltage_kV
    up = [t for t in res.transitions if t.kind == "spinodal" and t.direction == "up"]
    down = [t for t in res.transitions if t.kind == "spinodal" and t.direction == "down"]
    end = [t for t in res.transitions if t.kind == "no_stable_state"]
    out = {
        "up_spinodal": up[0],
        "range_end": end[0],
        "down_fold": down[0],
        "equal_free_energy": res.equal_free_energy[0],
    }
    return {k: {"kV": float(kv(t.phi_hat)), "error_kV": float(kv(t.phi_hat_error))} for k, t in out.items()}


# --- the baseline --------------------------------------------------------------------------------------
class ScipyBaseline:
    """The default scene's ramp, written the way a skilled scipy user would (see the module docstring).

    Only the model and the gas come from :class:`~coexist.simulation.Simulation`; every state is a
    root of ``scipy.optimize.root`` on residuals of :func:`~coexist.shooting.solve_states`.
    """

    def __init__(self, scene, landing_guess):
        self.scene = scene
        sim = Simulation.from_scene(scene)
        self.model, self.gas, self.settings = sim.model, sim.gas, sim.settings
        self.closing_stretch = sim.closing_stretch
        self.N = scene.zone_count
        if self.N != 3:
            raise ValueError("the baseline is written for the default scene (3 zones)")
        self.tol = BISECT_KV * 1e3 / scene.voltage_of(1.0)  # the bisection bracket in Φ̂
        self.landing_guess = np.round(np.asarray(landing_guess, dtype=float), 1)
        self.shots = 0  # solve_states calls

    def shoot(self, lams, phi):
        if not np.all(np.asarray(lams) > self.model.prestretch):
            return None  # root stepped out of the model's range
        self.shots += 1
        return solve_states(self.model, lams, phi, self.settings)

    # residuals: a large constant where a state is invalid (hybr then shortens its step)
    def homogeneous_residual(self, x, phi):
        st = self.shoot(x, phi)
        if st is None or not st.ok[0]:
            return np.array([1e3])
        return np.array([st.p_hat[0] - self.gas.pressure(self.N * st.v_hat[0])])

    def bulged_residual(self, x, phi):
        st = self.shoot(x, phi)
        if st is None or not st.ok.all():
            return np.array([1e3, 1e3])
        pu, pb = st.p_hat
        vu, vb = st.v_hat
        return np.array([pu - pb, pu - self.gas.pressure(2 * vu + vb)])

    def solve(self, residual, x0, phi):
        """The root from ``x0`` at ``Φ̂ = phi``, or None when it does not converge."""
        sol = root(residual, np.asarray(x0, dtype=float), args=(phi,), method="hybr", options={"xtol": 1e-13})
        if np.all(np.isfinite(sol.fun)) and np.max(np.abs(sol.fun)) <= RESIDUAL_TOL:
            return sol.x
        return None

    def dp_dl(self, lam, phi):
        h = DIFF_STEP
        p = self.shoot(lam + h * np.array([-2.0, -1.0, 1.0, 2.0]), phi).p_hat
        return (p[0] - 8 * p[1] + 8 * p[2] - p[3]) / (12 * h)

    def free_energy(self, x, phi):
        """``G = Σ n Ψ̂ + G_gas`` of a homogeneous (``x = [λ]``) or one-bulged (``x = [λu, λb]``) state."""
        st = self.shoot(x, phi)
        n = np.array([3.0]) if len(x) == 1 else np.array([2.0, 1.0])
        return float(n @ st.psi_hat + self.gas.free_energy(float(n @ st.v_hat)))

    def bisect(self, lo, hi, x_lo, good):
        """Bisect between ``lo`` (where ``good`` holds, with state ``x_lo``) and ``hi`` (where it does not)
        to ``self.tol``; ``good(phi, x_guess)`` returns the state or None. Returns ``(phi, x)`` at the
        midpoint of the last bracket and the last good state."""
        while abs(hi - lo) > self.tol:
            mid = 0.5 * (lo + hi)
            x = good(mid, x_lo)
            if x is not None:
                lo, x_lo = mid, x
            else:
                hi = mid
        return 0.5 * (lo + hi), x_lo

    def run(self) -> dict:
        path = np.asarray(self.scene.voltage_hat_path, dtype=float)
        top = int(np.argmax(path))
        up, down = path[: top + 1], path[top:]
        states = {"up": [], "down": []}  # one entry per voltage: None or the pole stretches
        homog = {}

        def homogeneous_stable(phi, guess):
            x = self.solve(self.homogeneous_residual, guess, phi)
            return x if x is not None and self.dp_dl(x[0], phi) > 0 else None

        def bulged(phi, guess):
            return self.solve(self.bulged_residual, guess, phi)

        # 1. the homogeneous state up to the loss of its stability
        x, prev, lost = np.array([self.closing_stretch]), None, None
        for k, phi in enumerate(up):
            new = homogeneous_stable(phi, x)
            if new is None:
                lost = k
                break
            x, prev = new, phi
            homog[phi] = x
            states["up"].append(x)
        if lost is None or prev is None:
            raise RuntimeError("the homogeneous state is stable all the way up, or not at the start")
        phi_up, _ = self.bisect(prev, up[lost], x, homogeneous_stable)
        # 2. the jump's target, from a rough guess, and the bulged state up to where it stops
        xb = bulged(phi_up, self.landing_guess)
        if xb is None:
            raise RuntimeError("no one-bulged state from the guess")
        landing, prev = xb, phi_up
        phi_end = None
        bulged_up = {}
        for phi in up[lost:]:
            if phi_end is not None:
                states["up"].append(None)
                continue
            new = bulged(phi, xb)
            if new is None:
                phi_end, _ = self.bisect(prev, phi, xb, bulged)
                states["up"].append(None)
                continue
            xb, prev = new, phi
            bulged_up[phi] = xb
            states["up"].append(xb)
        if phi_end is None:
            raise RuntimeError("the bulged state does not end below the top of the ramp")
        # 3. down: nothing above the end, then the bulged state down to its fold (the states of the way up
        # reused where it has them), then the homogeneous states of the way up
        phi_fold = None
        bulged_down = []  # (phi, x) on the grid, for the free energy
        for phi in down[1:]:
            if phi > phi_end:
                states["down"].append(None)
                continue
            if phi_fold is None:
                new = bulged_up.get(phi)
                if new is None:
                    new = bulged(phi, xb)
                if new is not None:
                    xb, prev = new, phi
                    bulged_down.append((phi, xb))
                    states["down"].append(xb)
                    continue
                phi_fold, _ = self.bisect(prev, phi, xb, bulged)
            states["down"].append(homog[phi])
        if phi_fold is None:
            raise RuntimeError("the bulged state reaches the end of the ramp")

        # 4. equal free energy: sign change of G_bulged − G_homogeneous on the grid, then bisected
        def dG(phi, xb_guess, xh_guess):
            xb_ = bulged(phi, xb_guess)
            xh_ = self.solve(self.homogeneous_residual, xh_guess, phi)
            if xb_ is None or xh_ is None:
                raise RuntimeError(f"a state is lost at Φ̂ = {phi:.12g} while bisecting the free energies")
            return self.free_energy(xb_, phi) - self.free_energy(xh_, phi), xb_, xh_

        signs = [
            (phi, xb_, self.free_energy(xb_, phi) - self.free_energy(homog[phi], phi))
            for phi, xb_ in bulged_down
            if phi in homog
        ]
        cross = [(a, b) for a, b in zip(signs, signs[1:]) if np.sign(a[2]) != np.sign(b[2])]
        if len(cross) != 1:
            raise RuntimeError(f"{len(cross)} sign changes of G_bulged − G_homogeneous on the grid")
        (lo, xb_lo, g_lo), (hi, _, _) = cross[0]
        xh_lo = homog[lo]
        while abs(hi - lo) > self.tol:
            mid = 0.5 * (lo + hi)
            g, xb_m, xh_m = dG(mid, xb_lo, xh_lo)
            if np.sign(g) == np.sign(g_lo):
                lo, xb_lo, xh_lo = mid, xb_m, xh_m
            else:
                hi = mid
        phi_eq = 0.5 * (lo + hi)
        kv = lambda phi: float(self.scene.voltage_of(phi) / 1e3)  # noqa: E731
        return {
            "up_spinodal": kv(phi_up),
            "range_end": kv(phi_end),
            "down_fold": kv(phi_fold),
            "equal_free_energy": kv(phi_eq),
            "landing_guess": [float(v) for v in self.landing_guess],
            "landing_pole_stretch": [float(v) for v in landing],
            "states": states["up"] + states["down"],
            "voltages": len(path),
            "solve_states_calls": self.shots,
        }


def run_baseline(scene, landing_guess):
    b = ScipyBaseline(scene, landing_guess)
    return b.run()


# --- the parts of the benchmark --------------------------------------------------------------------------
def bench_default(repeats: int) -> dict:
    scene = load_scene(SCENE)
    log("warm-up run of the default ramp ...")
    compute(scene)
    log(f"default ramp, best of {repeats} ...")
    best, times, report = best_of(lambda: compute(scene), repeats)
    no_err = SolverSettings(error_estimates=False)
    times_ne, times_err = [], []
    for _ in range(repeats):
        t0 = time.perf_counter()
        sim = Simulation.from_scene(scene, no_err)
        r = sim.ramp()
        t1 = time.perf_counter()
        sim.measure_errors(r.result.transitions + r.result.equal_free_energy)  # what error_estimates adds
        times_ne.append(t1 - t0)
        times_err.append(time.perf_counter() - t1)
    best_b, times_b, _ = best_of(lambda: Simulation.from_scene(scene), repeats)
    return {
        "default": {
            "voltages": len(scene.voltage_hat_path),
            "states_printed": sum(s.state is not None for s in report.result.steps),
            "seconds": spread(times),
            "no_error_estimates_seconds": spread(times_ne),
            "measure_errors_seconds": spread(times_err),
            "from_scene_seconds": spread(times_b),
            "transitions": transition_voltages(report),
        },
        "_report": report,
    }


def bench_baseline(report, repeats: int) -> dict:
    scene = load_scene(SCENE)
    landing = report.result.transitions[0].state_after.pole_stretch
    log("scipy baseline ...")
    t0 = time.perf_counter()
    out = run_baseline(scene, landing)
    times = [time.perf_counter() - t0]
    if times[0] < BASELINE_SINGLE_RUN_S:
        for _ in range(repeats - 1):
            t0 = time.perf_counter()
            run_baseline(scene, landing)
            times.append(time.perf_counter() - t0)
    fast = transition_voltages(report)
    diff = {k: abs(out[k] - fast[k]["kV"]) for k in fast}
    # the printed states, voltage by voltage: the same configuration and pole stretches
    mine = out.pop("states")
    theirs = [None if s.state is None else s.state.pole_stretch for s in report.result.steps]
    if len(mine) != len(theirs) or any(
        (a is None) != (b is None) or (a is not None and len(a) != len(b)) for a, b in zip(mine, theirs)
    ):
        raise AssertionError("the baseline prints states at other voltages or in other configurations")
    out["states_printed"] = sum(a is not None for a in mine)
    out["state_difference"] = float(
        max(np.max(np.abs(np.asarray(a) - np.asarray(b))) for a, b in zip(mine, theirs) if a is not None)
    )
    out["seconds"] = spread(times)
    out["difference_kV"] = diff
    bad = {k: v for k, v in diff.items() if not v <= AGREE_KV and k != "range_end"}
    if not (out["range_end"] <= fast["range_end"]["kV"] + AGREE_KV and diff["range_end"] <= PULL_IN_AGREE_KV):
        bad["range_end"] = diff["range_end"]
    if bad:
        raise AssertionError(f"baseline and fast path disagree by more than {AGREE_KV} kV: {bad}")
    return {"baseline": out}


def bench_zones(repeats: int) -> dict:
    rows = []
    for n in ZONE_COUNTS:
        scene = scene_variant(count=n)
        log(f"count = {n}: warm-up, then best of {repeats} ...")
        compute(scene)
        best, times, report = best_of(lambda scene=scene: compute(scene), repeats)
        rows.append(
            {
                "count": n,
                "seconds": spread(times),
                "transitions": [
                    f"{t.kind} ({t.event}) {t.direction} {report.voltage_kV(t.phi_hat):.7f}"
                    for t in report.result.transitions
                ],
            }
        )
    return {"zones": rows, "zones_ratio_1000_to_3": rows[-1]["seconds"]["best"] / rows[0]["seconds"]["best"]}


def bench_voltages(repeats: int) -> dict:
    rows = []
    for stop, step in VOLTAGE_VARIANTS:
        scene = scene_variant(stop_kV=stop, step_kV=step)
        log(f"stop_kV = {stop}, step_kV = {step}: warm-up, best of {repeats}, then a tracemalloc run ...")
        compute(scene)
        best, times, report = best_of(lambda scene=scene: compute(scene), repeats)
        tracemalloc.start()
        compute(scene)
        _, peak = tracemalloc.get_traced_memory()
        tracemalloc.stop()
        rows.append(
            {
                "stop_kV": stop,
                "step_kV": step,
                "voltages": len(scene.voltage_hat_path),
                "states_printed": sum(s.state is not None for s in report.result.steps),
                "seconds": spread(times),
                "peak_MB": peak / 1e6,
            }
        )
    return {"voltages": rows}


def bench_phase() -> dict:
    from coexist.coexistence import phase_diagram
    from coexist.model import build_model

    log("phase diagram ...")
    model = build_model("gent", 40.0)
    t0 = time.perf_counter()
    d = phase_diagram(model, np.linspace(0, 0.36, 37), 0.95 * np.sqrt(43 / 2))
    return {
        "phase_diagram": {
            "seconds": time.perf_counter() - t0,
            "critical_phi_hat": None if d.critical_point is None else float(d.critical_point[0]),
        }
    }


def bench_help() -> dict:
    log("coexist --help ...")
    times = []
    for _ in range(5):
        t0 = time.perf_counter()
        subprocess.run([sys.executable, "-m", "coexist", "--help"], check=True, capture_output=True)
        times.append(time.perf_counter() - t0)
    return {"help": {"mean_seconds": float(np.mean(times)), "min_seconds": float(np.min(times))}}


def fmt_t(s: dict) -> str:
    return f"{s['best']:.2f} s (worst {s['worst']:.2f}, {s['runs']} runs)"


def print_table(out: dict) -> None:
    d, b = out["default"], out["baseline"]
    print(f"machine: {out['machine']}; times are best of N after a warm-up (worst in brackets)")
    print(f"\n1. default ramp ({SCENE}, {d['voltages']} voltages, {d['states_printed']} states printed)")
    print(f"   from_scene + ramp                : {fmt_t(d['seconds'])}")
    print(f"   ... without error estimates      : {fmt_t(d['no_error_estimates_seconds'])}")
    print(f"   ... from_scene alone             : {fmt_t(d['from_scene_seconds'])}")
    m = d["measure_errors_seconds"]
    print(
        f"   ... the error measurement alone  : {m['best']:.3f} s (worst {m['worst']:.3f}, {m['runs']} runs; "
        f"Simulation.measure_errors on the transitions of a ramp run without it)"
    )
    print(
        f"\n2. scipy baseline (root/hybr + bisection, same states): {fmt_t(b['seconds'])}, "
        f"{b['solve_states_calls']} solve_states calls, {b['states_printed']} states printed"
    )
    print(
        f"   ratio baseline / fast path: {b['seconds']['best'] / d['seconds']['best']:.1f}x (/ fast path without "
        f"error estimates: {b['seconds']['best'] / d['no_error_estimates_seconds']['best']:.1f}x)"
    )
    print(f"   {'voltage (kV)':<18} {'fast path':>14} {'± error':>9} {'baseline':>14} {'|difference|':>12}")
    for k, t in d["transitions"].items():
        print(f"   {k:<18} {t['kV']:>14.9f} {t['error_kV']:>9.1e} {b[k]:>14.9f} {b['difference_kV'][k]:>12.1e}")
    print(f"   printed states: same voltages and configurations; pole stretches agree to {b['state_difference']:.1e}")
    print(f"   baseline's jump target found from the guess {b['landing_guess']} (the fast path's, rounded)")
    print("\n3. cost against the number of zones (from_scene + ramp)")
    for r in out["zones"]:
        print(f"   N = {r['count']:>4}: {fmt_t(r['seconds'])}   transitions: {'; '.join(r['transitions']) or '-'}")
    print(f"   ratio N = 1000 / N = 3: {out['zones_ratio_1000_to_3']:.2f}")
    kinds = [{t.split()[0] for t in r["transitions"]} for r in out["zones"]]
    if kinds[0] != kinds[-1]:
        print(
            f"   (not like for like: N = {out['zones'][0]['count']} meets {sorted(kinds[0])}, "
            f"N = {out['zones'][-1]['count']} only {sorted(kinds[-1])}: its jump finds no stable state, "
            "so no bulged branch is traced)"
        )
    print("\n4. cost and memory against the voltage range and step (from_scene + ramp)")
    print(f"   {'stop_kV':>7} {'step_kV':>7} {'voltages':>8} {'states':>6} {'time':>30} {'peak MB':>8}")
    for r in out["voltages"]:
        print(
            f"   {r['stop_kV']:>7g} {r['step_kV']:>7g} {r['voltages']:>8} {r['states_printed']:>6} "
            f"{fmt_t(r['seconds']):>30} {r['peak_MB']:>8.1f}"
        )
    p, h = out["phase_diagram"], out["help"]
    print(
        f"\n5. phase diagram (Gent Jlim 40, 37 Φ̂, one run): {p['seconds']:.2f} s (critical Φ̂ = {p['critical_phi_hat']})"
    )
    print(f"   coexist --help: {h['mean_seconds'] * 1e3:.0f} ms mean of 5 (min {h['min_seconds'] * 1e3:.0f} ms)")
    print(f"\nscript runtime: {out['script_seconds']:.0f} s")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--json", action="store_true", help="results as JSON on stdout (progress on stderr)")
    ap.add_argument("--quick", action="store_true", help="one timed run per item (to check the script)")
    args = ap.parse_args()
    t_start = time.perf_counter()
    r5, r3 = (1, 1) if args.quick else (5, 3)
    out = {
        "machine": f"{platform.machine()}, {platform.python_version()}, numpy {np.__version__}, "
        f"scipy {scipy.__version__}"
    }
    out.update(bench_help())
    out.update(bench_default(r5))
    report = out.pop("_report")
    out.update(bench_baseline(report, r3))
    out.update(bench_zones(r3))
    out.update(bench_voltages(r3))
    out.update(bench_phase())
    out["script_seconds"] = time.perf_counter() - t_start
    if args.json:
        print(json.dumps(out, indent=1, sort_keys=True))
    else:
        print_table(out)


if __name__ == "__main__":
    main()
