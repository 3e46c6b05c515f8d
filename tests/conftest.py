"""Shared fixtures and helpers (imported by the test modules as ``from conftest import ...``).

Models are built once per session (building one takes ~50 ms).
"""

import signal
import time
from contextlib import contextmanager

import numpy as np
import pytest

from coexist.effects import Gent, IdealDielectric, NeoHookean
from coexist.model import MembraneModel
from coexist.settings import SolverSettings

#: the tightest setting the tests compare against (integrator rtol 1e-12)
TIGHT = SolverSettings(rtol=1e-12)
#: wall-clock limit of any single library call under :func:`bounded` (s); the machine is shared, so generous
CALL_LIMIT = 30.0


@contextmanager
def time_limit(seconds: float = CALL_LIMIT):
    """Fail (TimeoutError) if the block runs longer than ``seconds`` of wall-clock time (``SIGALRM``)."""

    def _expired(signum, frame):
        raise TimeoutError(f"call did not return within {seconds:g} s")

    previous = signal.signal(signal.SIGALRM, _expired)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    start = time.perf_counter()
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)
    assert time.perf_counter() - start < seconds


def bounded(fn, *args, seconds: float = CALL_LIMIT, **kwargs):
    """``fn(*args, **kwargs)`` under :func:`time_limit`."""
    with time_limit(seconds):
        return fn(*args, **kwargs)


def cheb_nodes(a: float, b: float, n: int) -> np.ndarray:
    """The ``n`` Chebyshev points of the first kind on ``[a, b]``, ascending."""
    k = np.arange(n)
    return np.sort(0.5 * (a + b) + 0.5 * (b - a) * np.cos(np.pi * (k + 0.5) / n))


@pytest.fixture(scope="session")
def neo_hookean():
    return MembraneModel(NeoHookean(), IdealDielectric())


@pytest.fixture(scope="session")
def gent97():
    return MembraneModel(Gent(97.0), IdealDielectric())
