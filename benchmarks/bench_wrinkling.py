"""Benchmark: a curve through wrinkled segments against a taut one (issue 12's target: at most 2×).

The issue's target is "a curve through wrinkled segments costs at most 2× a taut one". The curve is the default
scene's zone (``tricircle``: Gent, Jlim 97, no prestretch, ``wrinkling = "tension-field"``), default settings
(rtol 1e-10), on the re-stiffened branch ``λ0 = linspace(6.0, 7.0, 200)`` where the bulged zone of the ramp lives:

- **curve, wrinkled band** (the target's numerator): :func:`coexist.curves.pressure_volume_curve` at 3.5 kV, where
  the states ``6.39 ≲ λ0 ≲ 6.79`` (81 of the 200) are hoop-wrinkled near their clamp and the others taut;
- **taut curve** (the target's denominator): the same call on the same 200 pole stretches at 3.0 kV, where every
  state is taut. This is the fair comparison: the same model, the same number of states on the same grid, the same
  work per state except that 40 % of them go through a wrinkled segment (the taut shot that finds the onset, the
  switch, the relaxed segment to the clamp). The ratio **curve, wrinkled band / taut curve** is the target;
- **curve, refuse** (for reference, not the target): the same curve at 3.5 kV with ``wrinkling = "refuse"``, where
  the band has no states (its shots stop at the onset of wrinkling), so it does less work than a curve of 200
  states: the ratio to it says what computing the wrinkled states adds to refusing them;
- the same three sets of states by :func:`coexist.shooting.solve_states` with exact derivatives (what the ramp's
  equilibria use);
- **all wrinkled**: 200 states every one of which wraps a wrinkled segment (``λ0 = linspace(1.015, 1.045, 200)``
  and ``linspace(5.95, 6.9, 200)`` at ``Φ̂ = 0.3``, Gent 97) against the same pole stretches at ``Φ̂ = 0.1``, where
  every one is taut (like for like), and against 200 other taut ones (``λ0 = linspace(1.1, 3, 200)``, the
  comparison of the first version of this script: it mixes in the cost of other pole stretches), without and with
  derivatives: the worst case, every state pays the switch;
- **baseline**: the scipy shooting of one wrinkled state at a time
  (:func:`coexist.studies.wrinkled_shooting.shoot_relaxed`, ``solve_ivp`` DOP853 with located events, at the
  same rtol) on 20 of the low wrinkled states, scaled to 200: what a skilled user would write.

One process; a warm-up first (which also compiles the small-batch steppers, once per machine); then ``REPEATS``
rounds, each timing every case once in turn (interleaved, so that a slow spell of the shared machine hits all
cases alike); best and median wall time and best process CPU time per case; ratios of the best CPU times (and of
the medians). Run with ``.venv/bin/python benchmarks/bench_wrinkling.py``; it takes about half a minute.
"""

from __future__ import annotations

import dataclasses
import statistics
import time

import numpy as np

from coexist.curves import pressure_volume_curve
from coexist.model import build_model
from coexist.scene import load_scene
from coexist.shooting import solve_states
from coexist.simulation import Simulation
from coexist.studies.wrinkled_shooting import shoot_relaxed

REPEATS = 9
#: the curve: the default scene's zone on its re-stiffened branch, with a wrinkled band at 3.5 kV, taut at 3.0 kV
GRID = np.linspace(6.0, 7.0, 200)
BAND_KV, TAUT_KV = 3.5, 3.0


def _run(cases: dict) -> dict:
    """Time every case ``REPEATS`` times, interleaved: ``{name: (best wall, median wall, best CPU, median CPU)}``."""
    wall: dict = {k: [] for k in cases}
    cpu: dict = {k: [] for k in cases}
    for _ in range(REPEATS):
        for name, fn in cases.items():
            w, c = time.perf_counter(), time.process_time()
            fn()
            wall[name].append(time.perf_counter() - w)
            cpu[name].append(time.process_time() - c)
    return {k: (min(wall[k]), statistics.median(wall[k]), min(cpu[k]), statistics.median(cpu[k])) for k in cases}


def _line(name: str, t: tuple, note: str) -> str:
    return (
        f"  {name:<34} best {t[0] * 1e3:7.1f} ms, median {t[1] * 1e3:7.1f} ms, CPU best {t[2] * 1e3:7.1f} ms"
        f"{'; ' + note if note else ''}"
    )


def _ratio(a: tuple, b: tuple) -> str:
    return f"{a[2] / b[2]:.2f}x (medians {a[3] / b[3]:.2f}x)"


def main() -> None:
    sim = Simulation.from_scene(load_scene("tricircle"))
    tf = sim.model
    refuse = dataclasses.replace(tf, wrinkling="refuse")
    phi_band, phi_taut = sim.scene.phi_hat(BAND_KV * 1e3), sim.scene.phi_hat(TAUT_KV * 1e3)
    gent = build_model("gent", 97, wrinkling="tension-field")
    low, high = np.linspace(1.015, 1.045, 200), np.linspace(5.95, 6.9, 200)
    batches = {
        "taut (Φ̂ 0.1)": (np.linspace(1.1, 3.0, 200), 0.1),
        "wrinkled, low (Φ̂ 0.3)": (low, 0.3),
        "wrinkled, high (Φ̂ 0.3)": (high, 0.3),
        # like for like: the same pole stretches at a voltage where every state is taut
        "taut, low (Φ̂ 0.1)": (low, 0.1),
        "taut, high (Φ̂ 0.1)": (high, 0.1),
    }
    # warm-up: builds and compiles every stepper and attempt function the runs use (small batches first: the
    # attempt functions are compiled after a dozen uses)
    for model, phi in ((tf, phi_band), (tf, phi_taut), (refuse, phi_band)):
        for derivatives in (False, True):
            for _ in range(14):
                solve_states(model, GRID[:3], phi, derivatives=derivatives)
                solve_states(model, GRID[95:98], phi, derivatives=derivatives)
            solve_states(model, GRID, phi, derivatives=derivatives)
        pressure_volume_curve(model, phi, GRID)
    for l0, phi in batches.values():
        for derivatives in (False, True):
            for _ in range(14):
                solve_states(gent, l0[:3], phi, derivatives=derivatives)
            solve_states(gent, l0, phi, derivatives=derivatives)

    band = pressure_volume_curve(tf, phi_band, GRID).states
    taut = pressure_volume_curve(tf, phi_taut, GRID).states
    ref = pressure_volume_curve(refuse, phi_band, GRID).states
    n_band = int(np.sum(band.wrinkled_fraction > 0))
    print(
        "tricircle zone (Gent 97, λpre 1, tension-field), rtol 1e-10, λ0 = linspace(6, 7, 200); "
        f"{REPEATS} interleaved rounds\n  at {BAND_KV} kV (Φ̂ {phi_band:.4f}): {int(band.ok.sum())} states, "
        f"{n_band} wrinkled; at {TAUT_KV} kV (Φ̂ {phi_taut:.4f}): {int(taut.ok.sum())} states, "
        f"{int(np.sum(taut.wrinkled_fraction > 0))} wrinkled; refuse at {BAND_KV} kV: {int(ref.ok.sum())} states"
    )
    curves = {
        "curve, wrinkled band": lambda: pressure_volume_curve(tf, phi_band, GRID),
        "taut curve": lambda: pressure_volume_curve(tf, phi_taut, GRID),
        "curve, refuse": lambda: pressure_volume_curve(refuse, phi_band, GRID),
        "states+derivatives, wrinkled band": lambda: solve_states(tf, GRID, phi_band, derivatives=True),
        "states+derivatives, taut": lambda: solve_states(tf, GRID, phi_taut, derivatives=True),
        "states+derivatives, refuse": lambda: solve_states(refuse, GRID, phi_band, derivatives=True),
    }
    for derivatives in (False, True):
        for name, (l0, phi) in batches.items():
            curves[f"{name}{', deriv.' if derivatives else ''}"] = lambda l0=l0, phi=phi, d=derivatives: solve_states(
                gent, l0, phi, derivatives=d
            )
    t = _run(curves)
    for name in list(curves)[:6]:
        print(_line(name, t[name], ""))
    print(
        f"  TARGET ratio curve, wrinkled band / taut curve: {_ratio(t['curve, wrinkled band'], t['taut curve'])} "
        "(issue 12: at most 2x)"
    )
    print(f"  ratio curve, wrinkled band / curve, refuse: {_ratio(t['curve, wrinkled band'], t['curve, refuse'])}")
    print(
        "  ratio states+derivatives, wrinkled band / taut: "
        f"{_ratio(t['states+derivatives, wrinkled band'], t['states+derivatives, taut'])}"
    )
    print("all wrinkled (every state pays a switch), Gent 97, 200 states:")
    for derivatives in (False, True):
        suffix = ", deriv." if derivatives else ""
        for name, (l0, phi) in batches.items():
            st = solve_states(gent, l0, phi, derivatives=derivatives)
            note = f"{int(st.ok.sum())} states, {int(np.sum(st.wrinkled_fraction > 0))} wrinkled"
            print(_line(name + suffix, t[name + suffix], note))
        for side in ("low", "high"):
            name, same = f"wrinkled, {side} (Φ̂ 0.3)", f"taut, {side} (Φ̂ 0.1)"
            print(
                f"  ratio {name}{suffix} / the same λ0 taut: {_ratio(t[name + suffix], t[same + suffix])}; "
                f"/ taut (Φ̂ 0.1, λ0 1.1..3): {_ratio(t[name + suffix], t['taut (Φ̂ 0.1)' + suffix])}"
            )
    l0, phi = batches["wrinkled, low (Φ̂ 0.3)"]
    sample = l0[::10]
    w = time.perf_counter()
    for x in sample:
        shoot_relaxed(build_model("gent", 97), float(x), phi, rtol=1e-10)
    per = (time.perf_counter() - w) / sample.size
    ours = t["wrinkled, low (Φ̂ 0.3)"][0]
    print(
        f"baseline (scipy, one state at a time): {per * 1e3:.1f} ms per state, {per * 200:.2f} s for 200; "
        f"ratio baseline / project (wrinkled, low) {per * 200 / ours:.0f}x"
    )


if __name__ == "__main__":
    main()
