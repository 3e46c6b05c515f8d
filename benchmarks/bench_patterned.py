"""Benchmark: a patterned zone's p̂–V̂ curve against the uniform zone's (issue 13's target: within 3×), and a
patterned three-zone ramp against the same scene with full electrodes.

**Curves** (``REPEATS`` runs each, interleaved after a warm-up): Gent ``Jlim = 97`` at ``Φ̂ = 0.1`` on the
default grid (200 pole stretches from 1.01 to 4, default settings, rtol 1e-10), the pressure maximum located:

- **uniform** (baseline): :func:`coexist.curves.pressure_volume_curve`, one integration per state (the
  ``R → cR, p → p/c`` scaling) by the compiled attempt function;
- **inner-circle-0.5-two-layers** (the headline): :func:`coexist.patterned.patterned_pressure_volume_curve` for
  an electrode disc of half the radius (one layer) in a two-layer passive annulus; and, for comparison, the same
  disc with a one-layer annulus and an electrode ring ``0.3 < R/A < 0.7``: one Newton iteration on the interface
  scales of the grid (a coarse eighth, evenly spaced in ``(λ0/λpre − 1)^0.4``, started from the pole region's
  uniform zone; the rest joining once the coarse residuals are small, from the polynomial through their scales
  with interpolated slopes and interface stretches), region by region with the compiled attempt functions; the
  passes after the first take up the pole region where the first stopped and skip the variational equations
  where the residual is already small.

**Ramps** (``RAMP_REPEATS`` runs each, interleaved): the built-in tricircle with ``wrinkling = "refuse"``, with full
electrodes (baseline) and with inner-circle electrodes of 0.8 of the zone radius (one passive layer), 0 → 5 kV
→ 0 (501 voltages), :meth:`coexist.simulation.Simulation.ramp` from the scene (model, gas, closing state,
continuation). Best and median wall time and the ratio of the best times (the machine is shared: medians
wander). Run with ``.venv/bin/python benchmarks/bench_patterned.py`` (``--json`` for machine-readable output).
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time

from coexist.curves import pressure_volume_curve
from coexist.effects import Gent
from coexist.model import MembraneModel
from coexist.patterned import ZonePattern, patterned_pressure_volume_curve
from coexist.scene import builtin_scene_text, parse_scene
from coexist.simulation import Simulation

PHI_HAT = 0.1
REPEATS = 7
RAMP_REPEATS = 2
HEADLINE = "inner-circle-0.5-two-layers"
PATTERNS = {
    HEADLINE: ZonePattern.inner_circle(0.5, passive_layers=2),
    "inner-circle-0.5": ZonePattern.inner_circle(0.5),
    "ring-0.3-0.7": ZonePattern.ring(0.3, 0.7),
}
#: the tricircle, taut (a patterned zone refuses wrinkled states), with full or inner-circle electrodes
UNIFORM_SCENE = builtin_scene_text("tricircle").replace('wrinkling = "tension-field"', 'wrinkling = "refuse"')
PATTERNED_SCENE = UNIFORM_SCENE.replace(
    "[zones]", '[electrodes]\npattern = "inner-circle"\ninner_fraction = 0.8\n\n[zones]'
)


def _timed(runs: dict, repeats: int, record) -> dict[str, list[float]]:
    times: dict[str, list[float]] = {name: [] for name in runs}
    for _ in range(repeats):
        for name, run in runs.items():
            start = time.perf_counter()
            out = run()
            times[name].append(time.perf_counter() - start)
            record(name, out)
    return times


def _report(times, base_name, extra, log) -> dict:
    base = min(times[base_name])
    result = {}
    for name, t in times.items():
        result[name] = {"best_s": min(t), "median_s": statistics.median(t), "ratio_to_uniform": min(t) / base}
        result[name].update(extra.get(name, {}))
        print(
            f"{name:30s} best {min(t) * 1e3:8.1f} ms  median {statistics.median(t) * 1e3:8.1f} ms  "
            f"ratio {min(t) / base:5.2f}  " + "  ".join(f"{k} {v}" for k, v in extra.get(name, {}).items()),
            file=log,
        )
    return result


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--json", action="store_true", help="print the results as JSON on stdout")
    parser.add_argument("--repeats", type=int, default=REPEATS)
    parser.add_argument("--ramp-repeats", type=int, default=RAMP_REPEATS)
    args = parser.parse_args()
    log = sys.stderr if args.json else sys.stdout
    model = MembraneModel(Gent(97))
    runs = {"uniform": lambda: pressure_volume_curve(model, PHI_HAT)}
    for name, pattern in PATTERNS.items():
        runs[name] = lambda pattern=pattern: patterned_pressure_volume_curve(model, pattern, PHI_HAT)
    for run in runs.values():  # warm-up: generated code, compiled steppers and attempt functions
        run()
    maxima: dict = {}

    def curve_max(name, curve):
        maxima[name] = {"pressure_max": f"{curve.limit_points[0].p_hat:.10f}", "states": curve.states.p_hat.size}

    print(f"p̂–V̂ curves, Gent Jlim 97, Φ̂ = {PHI_HAT}, 200 pole stretches, rtol 1e-10:", file=log)
    result = {"curves": _report(_timed(runs, args.repeats, curve_max), "uniform", maxima, log)}
    print(
        f"headline: the patterned curve ({HEADLINE}) / the uniform one = "
        f"{result['curves'][HEADLINE]['ratio_to_uniform']:.2f}",
        file=log,
    )

    ramps = {
        "uniform": lambda: Simulation.from_scene(parse_scene(UNIFORM_SCENE)).ramp(),
        "inner-circle-0.8": lambda: Simulation.from_scene(parse_scene(PATTERNED_SCENE)).ramp(),
    }
    split: dict = {}

    def ramp_split(name, report):
        up = [t for t in report.result.transitions if t.kind == "spinodal" and t.direction == "up"]
        split[name] = {"split_kV": f"{report.voltage_kV(up[0].phi_hat):.6f}", "voltages": len(report.result.steps)}

    print("\nthree-zone ramps (tricircle, wrinkling refuse, 0 -> 5 kV -> 0):", file=log)
    result["ramps"] = _report(_timed(ramps, args.ramp_repeats, ramp_split), "uniform", split, log)
    if args.json:
        print(json.dumps(result, indent=2, sort_keys=True))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
