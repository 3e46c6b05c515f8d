"""The curve benchmark's two scipy baselines are independent implementations of the same membrane
equations (plain numpy right-hand side, scipy's DOP853, the pole series typed again): checked here
against the library's shooting, so the benchmark stays runnable and its ratios compare like with like."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest

from coexist.model import build_model
from coexist.settings import SolverSettings
from coexist.shooting import solve_states

SCRIPT = Path(__file__).resolve().parent.parent / "benchmarks" / "bench_curve.py"


@pytest.fixture(scope="module")
def bench():
    spec = importlib.util.spec_from_file_location("bench_curve", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)  # type: ignore[union-attr]
    return module


@pytest.mark.parametrize("phi", [0.0, 0.1])
def test_both_baselines_agree_with_the_library(bench, phi):
    """Neo-Hookean states at five pole stretches, the baselines at rtol 1e-10 against the library at rtol
    1e-12: ``p̂`` and ``V̂`` to 1e-9 relative (measured: at most 5e-11 and 6e-11)."""
    l0 = np.array([1.2, 1.6, 2.1, 2.8, 3.6])
    ref = solve_states(build_model("neo-hookean"), l0, phi, SolverSettings(rtol=1e-12))
    assert np.all(ref.ok)
    old = np.array([bench.baseline_state(x, phi, 1e-10) for x in l0])
    tuned = np.array([bench.tuned_state(x, phi, 1e-10)[:2] for x in l0])
    for states in (old, tuned):
        np.testing.assert_allclose(states[:, 0], ref.p_hat, rtol=1e-9, atol=0)
        np.testing.assert_allclose(states[:, 1], ref.v_hat, rtol=1e-9, atol=0)
