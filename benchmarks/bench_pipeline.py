"""Benchmark: the scene pipeline (issue 4's speed targets), fast path against a baseline, one run.

1. ``coexist ramp`` on the default scene (0 → 5 → 0 kV in 0.02 kV steps): compute time of
   ``prepare`` + ``simulate_ramp`` (one vectorised shooting of the curve family, interpolation in
   the voltage) against a baseline that shoots every voltage's curve directly (same grid, same
   ramp logic); prints both and the ratio.
2. The phase diagram (``coexist phase-diagram`` defaults: Gent Jlim = 40, 37 voltages).
3. ``coexist --help`` start-up time (heavy imports are lazy), mean of 5 runs in a subprocess.

Run: ``.venv/bin/python benchmarks/bench_pipeline.py [--json]``.
"""

from __future__ import annotations

import json
import subprocess
import sys
import time

import numpy as np


class DirectFamily:
    """Baseline: every curve shot directly at its own voltage (no interpolation in Φ̂)."""

    def __init__(self, family):
        self.family = family
        self.phi_max = family.phi_max
        self._cache = {}

    def curve(self, phi):
        from coexist.branches import ZoneCurve

        key = round(float(phi), 14)
        if key not in self._cache:
            f = self.family
            self._cache[key] = ZoneCurve.compute(f.model, float(phi), f.model.prestretch + f.u**2, f.settings)
        return self._cache[key]


def bench_ramp():
    from coexist.simulate import closed_gas, prepare, simulate_ramp

    from coexist.ramp import run_ramp
    from coexist.scene import load_scene

    scene = load_scene("tricircle")
    prepare(scene)  # warm-up (imports, CasADi model build)
    times = []
    for _ in range(3):
        t0 = time.perf_counter()
        prep = prepare(scene)
        report = simulate_ramp(scene, prep=prep)
        times.append(time.perf_counter() - t0)
    fast = min(times)
    up = [t for t in report.result.transitions if t.kind == "spinodal"][0]
    t0 = time.perf_counter()
    base = run_ramp(DirectFamily(prep.family), closed_gas(prep), scene.zone_count, scene.voltage_hat_path)
    slow = time.perf_counter() - t0
    base_up = [t for t in base.transitions if t.kind == "spinodal"][0]
    return {
        "ramp_seconds": fast,
        "ramp_baseline_seconds": slow,
        "ramp_ratio": slow / fast,
        "ramp_transition_kV": float(scene.voltage_of(up.phi_hat) / 1e3),
        "ramp_baseline_transition_kV": float(scene.voltage_of(base_up.phi_hat) / 1e3),
        "ramp_steps": len(scene.voltage_hat_path),
    }


def bench_phase():
    from coexist.coexistence import phase_diagram
    from coexist.model import build_model

    model = build_model("gent", 40.0)
    t0 = time.perf_counter()
    d = phase_diagram(model, np.linspace(0, 0.36, 37), 0.95 * np.sqrt(43 / 2))
    return {"phase_diagram_seconds": time.perf_counter() - t0,
            "critical_phi_hat": None if d.critical_point is None else float(d.critical_point[0])}


def bench_help():
    times = []
    for _ in range(5):
        t0 = time.perf_counter()
        subprocess.run([sys.executable, "-m", "coexist", "--help"], check=True, capture_output=True)
        times.append(time.perf_counter() - t0)
    return {"help_seconds_mean": float(np.mean(times)), "help_seconds_min": float(np.min(times))}


def main():
    out = {}
    for f in (bench_help, bench_ramp, bench_phase):
        out.update(f())
    if "--json" in sys.argv:
        print(json.dumps(out, indent=1, sort_keys=True))
        return
    print(f"coexist --help        : {out['help_seconds_mean'] * 1e3:.0f} ms mean "
          f"(min {out['help_seconds_min'] * 1e3:.0f} ms)")
    print(f"ramp ({out['ramp_steps']} steps)     : {out['ramp_seconds']:.2f} s  (baseline, direct curve per voltage: "
          f"{out['ramp_baseline_seconds']:.2f} s; ratio {out['ramp_ratio']:.1f}x)")
    print(f"  first jump          : {out['ramp_transition_kV']:.6f} kV "
          f"(baseline {out['ramp_baseline_transition_kV']:.6f} kV)")
    print(f"phase diagram (37 Φ̂)  : {out['phase_diagram_seconds']:.2f} s  (critical Φ̂ = {out['critical_phi_hat']})")


if __name__ == "__main__":
    main()
