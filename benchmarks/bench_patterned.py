"""Benchmark: a patterned zone's p̂–V̂ curve against the uniform zone's (issue 13's target: within 3×).

Both curves are neo-Hookean at ``Φ̂ = 0.1`` on the default grid (200 pole stretches from 1.01 to 4, default
settings, rtol 1e-10), the pressure maximum located:

- **uniform** (baseline): :func:`coexist.curves.pressure_volume_curve`, one integration per state (the
  ``R → cR, p → p/c`` scaling) by the compiled attempt function;
- **patterned**: :func:`coexist.patterned.patterned_pressure_volume_curve` for an electrode disc of half the
  radius (one layer / two-layer passive annulus) and an electrode ring ``0.3 < R/A < 0.7``: a Newton
  iteration on the interface scale per state (a coarse eighth of the grid from the cap estimate, the rest
  from the interpolated scales), region by region with the project's DOP853 steppers.

All in one process, interleaved after a warm-up, ``REPEATS`` runs each; best and median wall time, and the
ratio of the best times (the machine is shared: medians wander). Run with
``.venv/bin/python benchmarks/bench_patterned.py`` (``--json`` for machine-readable output).
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time

from coexist.curves import pressure_volume_curve
from coexist.model import MembraneModel
from coexist.patterned import ZonePattern, patterned_pressure_volume_curve

PHI_HAT = 0.1
REPEATS = 7
PATTERNS = {
    "inner-circle-0.5": ZonePattern.inner_circle(0.5),
    "inner-circle-0.5-two-layers": ZonePattern.inner_circle(0.5, passive_layers=2),
    "ring-0.3-0.7": ZonePattern.ring(0.3, 0.7),
}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--json", action="store_true", help="print the results as JSON on stdout")
    parser.add_argument("--repeats", type=int, default=REPEATS)
    args = parser.parse_args()
    log = sys.stderr if args.json else sys.stdout
    model = MembraneModel()
    runs = {"uniform": lambda: pressure_volume_curve(model, PHI_HAT)}
    for name, pattern in PATTERNS.items():
        runs[name] = lambda pattern=pattern: patterned_pressure_volume_curve(model, pattern, PHI_HAT)
    for run in runs.values():  # warm-up: generated code, compiled steppers
        run()
    times: dict[str, list[float]] = {name: [] for name in runs}
    maxima = {}
    for _ in range(args.repeats):
        for name, run in runs.items():
            start = time.perf_counter()
            curve = run()
            times[name].append(time.perf_counter() - start)
            maxima[name] = curve.limit_points[0].p_hat
    base = min(times["uniform"])
    result = {}
    for name, t in times.items():
        result[name] = {
            "best_s": min(t),
            "median_s": statistics.median(t),
            "ratio_to_uniform": min(t) / base,
            "pressure_max": maxima[name],
        }
        print(
            f"{name:30s} best {min(t) * 1e3:7.1f} ms  median {statistics.median(t) * 1e3:7.1f} ms  "
            f"ratio {min(t) / base:5.2f}  p_max {maxima[name]:.10f}",
            file=log,
        )
    if args.json:
        print(json.dumps(result, indent=2, sort_keys=True))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
