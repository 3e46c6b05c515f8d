"""A trajectory that an attempt call leaves exactly as it found it (but for its attempt count) is ended as running
on would end it (``coexist.shooting.run_attempts`` with the count's rows; helper-89).

A pole region asked to end below its series radius retried the same rejected step until its 4000-attempt budget ran
out, some 500 calls of the attempt function per trial: half the time of ``coexist coexistence`` on a prestretched
five-zone inner-circle scene. The shortcut must give bitwise the state and status of running on: checked here
against the plain loop on a model attempt function (fixed points, cycles of period 2 and 3 against 8 attempts a
call, limits at every offset in the cycle, trajectories that move, and ones that stop on their own).
"""

import numpy as np
import pytest

from coexist.numerics import dop853 as _int
from coexist.shooting import ATTEMPTS_PER_CALL, run_attempts

STATUS, STEPS, LIMIT, T, PERIOD, STOP = range(6)  # rows of the packed state


class Attempts:
    """``ATTEMPTS_PER_CALL`` attempts a call: ``t`` cycles through ``0, 1, ..., period − 1`` (period 1: stuck), or
    grows by 1 where the period is 0; a trajectory stops (status 1) when ``t`` reaches ``STOP``, and with
    ``STEP_LIMIT`` when its count reaches its limit, as the attempt functions do."""

    def __init__(self):
        self.calls = 0

    def __call__(self, X):
        self.calls += 1
        X = np.array(X, dtype=float, copy=True)
        for _ in range(ATTEMPTS_PER_CALL):
            active = X[STATUS] == 0
            period = X[PERIOD]
            t = np.where(period > 0, np.mod(X[T] + 1, np.maximum(period, 1)), X[T] + 1)
            X[T] = np.where(active, t, X[T])
            X[STATUS] = np.where(active & (X[T] >= X[STOP]), 1.0, X[STATUS])
            X[STEPS] = X[STEPS] + active
            X[STATUS] = np.where((X[STATUS] == 0) & (X[STEPS] >= X[LIMIT]), _int.STEP_LIMIT, X[STATUS])
        return X


def packed(periods, limits, stops):
    n = len(periods)
    X = np.zeros((6, n))
    X[LIMIT], X[PERIOD], X[STOP] = limits, periods, stops
    return X


def entry_of(fun):
    return {"fun": None, "maps": {n: fun for n in range(1, 64)}}


@pytest.mark.parametrize("limit", [4000, 4001, 4003, 4005, 4007, 37, 8, 9])
def test_stalled_columns_end_as_running_on_would(limit):
    periods = [1, 2, 3, 0, 0, 2]
    limits = [limit, limit, limit, limit, 50, limit + 1]
    stops = [np.inf, np.inf, np.inf, np.inf, 30, np.inf]
    plain, fast = packed(periods, limits, stops), packed(periods, limits, stops)
    slow_calls, quick = Attempts(), Attempts()
    run_attempts(entry_of(slow_calls), plain, STATUS)
    run_attempts(entry_of(quick), fast, STATUS, STEPS, LIMIT)
    assert np.array_equal(plain.view(np.int64), fast.view(np.int64))  # bitwise the same states and statuses
    assert (fast[STATUS] != 0).all()


@pytest.mark.parametrize("limit", [4000, 4003])
def test_stalled_columns_cost_three_calls_at_most(limit):
    """Stuck and period-2 columns (8 attempts a call bring them back): three calls at most (the first, one that finds
    them unchanged, one to the limit), not ~500."""
    plain, fast = packed([1, 2], [limit, limit], [np.inf, np.inf]), packed([1, 2], [limit, limit], [np.inf, np.inf])
    slow_calls, quick = Attempts(), Attempts()
    run_attempts(entry_of(slow_calls), plain, STATUS)
    run_attempts(entry_of(quick), fast, STATUS, STEPS, LIMIT)
    assert np.array_equal(plain.view(np.int64), fast.view(np.int64))
    assert (fast[STATUS] == _int.STEP_LIMIT).all() and (fast[STEPS] == limit).all()
    assert slow_calls.calls == -(-limit // ATTEMPTS_PER_CALL) and quick.calls <= 3
