"""Benchmark: curves through wrinkled segments against taut ones (issue 12's target: at most 2×).

Gent membrane (Jlim 97), tension-field model, default settings (rtol 1e-10), in one process, interleaved
after a warm-up (which also compiles the small-batch steppers), best and median of ``REPEATS`` runs, wall and
process CPU time (the machine may be shared):

- **taut**: :func:`coexist.shooting.solve_states` of 200 taut states (``λ0 = linspace(1.1, 3, 200)`` at
  ``Φ̂ = 0.1``), without and with derivatives;
- **wrinkled, low**: 200 barely inflated states under voltage, every one wrinkled from ``R̂ ≈ 0.7–0.9`` to the
  clamp (``λ0 = linspace(1.015, 1.045, 200)`` at ``Φ̂ = 0.3``);
- **wrinkled, high**: 200 states on the Gent re-stiffened branch, wrinkled from ``R̂ ≈ 0.2–0.8`` to the clamp
  (``λ0 = linspace(5.95, 6.9, 200)`` at ``Φ̂ = 0.3``);
- **curve**: :func:`coexist.curves.pressure_volume_curve` at ``Φ̂ = 0.3`` on ``linspace(1.015, 1.5, 200)``
  (its first states, below the onset near 1.047, wrinkled) against the taut model on ``linspace(1.06, 1.5, 200)``;
- **baseline**: the scipy shooting of one wrinkled state at a time
  (:func:`coexist.studies.wrinkled_shooting.shoot_relaxed`, ``solve_ivp`` DOP853 with located events, at the
  same rtol) on 20 of the low wrinkled states, scaled to 200: what a skilled user would write.

Run with ``.venv/bin/python benchmarks/bench_wrinkling.py``.
"""

from __future__ import annotations

import statistics
import time

import numpy as np

from coexist.curves import pressure_volume_curve
from coexist.model import build_model
from coexist.shooting import solve_states
from coexist.studies.wrinkled_shooting import shoot_relaxed

REPEATS = 7


def timed(fn):
    """Best and median wall time and best CPU time of ``REPEATS`` calls of ``fn``."""
    wall, cpu = [], []
    for _ in range(REPEATS):
        w, c = time.perf_counter(), time.process_time()
        fn()
        wall.append(time.perf_counter() - w)
        cpu.append(time.process_time() - c)
    return min(wall), statistics.median(wall), min(cpu)


def main() -> None:
    relaxed = build_model("gent", 97, wrinkling="tension-field")
    taut = build_model("gent", 97)
    cases = {
        "taut": (np.linspace(1.1, 3.0, 200), 0.1),
        "wrinkled, low": (np.linspace(1.015, 1.045, 200), 0.3),
        "wrinkled, high": (np.linspace(5.95, 6.9, 200), 0.3),
    }
    for l0, phi in cases.values():  # warm-up: builds and compiles every stepper the runs use
        for derivatives in (False, True):
            for _ in range(14):
                solve_states(relaxed, l0[:3], phi, derivatives=derivatives)
            solve_states(relaxed, l0, phi, derivatives=derivatives)
    results = {}
    for derivatives in (False, True):
        for name, (l0, phi) in cases.items():
            st = solve_states(relaxed, l0, phi, derivatives=derivatives)
            wrinkled = int(np.sum(st.wrinkled_fraction > 0))
            best, med, cpu = timed(lambda l0=l0, phi=phi, d=derivatives: solve_states(relaxed, l0, phi, derivatives=d))
            results[(name, derivatives)] = cpu
            print(
                f"{name:<15} derivatives={derivatives!s:<5}: best {best * 1e3:7.1f} ms, median {med * 1e3:7.1f} ms, "
                f"CPU {cpu * 1e3:7.1f} ms; {int(st.ok.sum())} states, {wrinkled} wrinkled, "
                f"{st.steps.mean():.0f} steps each"
            )
        for name in ("wrinkled, low", "wrinkled, high"):
            print(f"  ratio {name} / taut (CPU): {results[(name, derivatives)] / results[('taut', derivatives)]:.1f}x")
    grid_r, grid_t = np.linspace(1.015, 1.5, 200), np.linspace(1.06, 1.5, 200)
    pressure_volume_curve(relaxed, 0.3, grid_r)
    pressure_volume_curve(taut, 0.3, grid_t)
    c = pressure_volume_curve(relaxed, 0.3, grid_r)
    r_best, _, r_cpu = timed(lambda: pressure_volume_curve(relaxed, 0.3, grid_r))
    t_best, _, t_cpu = timed(lambda: pressure_volume_curve(taut, 0.3, grid_t))
    print(
        f"curve at Φ̂ 0.3: through wrinkled states {r_best * 1e3:.1f} ms (CPU {r_cpu * 1e3:.1f}; "
        f"{int(np.sum(c.states.wrinkled_fraction > 0))} of {c.states.p_hat.size} wrinkled), taut "
        f"{t_best * 1e3:.1f} ms (CPU {t_cpu * 1e3:.1f}): ratio {r_cpu / t_cpu:.1f}x (target 2x)"
    )
    l0, phi = cases["wrinkled, low"]
    sample = l0[::10]
    w = time.perf_counter()
    for x in sample:
        shoot_relaxed(taut, float(x), phi, rtol=1e-10)
    per = (time.perf_counter() - w) / sample.size
    ours = results[("wrinkled, low", False)]
    print(
        f"baseline (scipy, one state at a time): {per * 1e3:.1f} ms per state, {per * 200:.2f} s for 200; "
        f"ratio baseline / project {per * 200 / ours:.0f}x"
    )


if __name__ == "__main__":
    main()
