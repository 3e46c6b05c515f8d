"""CasADi functions called through preallocated numpy arrays (CasADi's buffer interface).

Calling a CasADi ``Function`` on numpy arrays converts every input to a CasADi matrix and the output back:
some 25 µs a call, more than the compiled DOP853 attempt of a few trajectories it runs. Bound once to
preallocated arrays, a call costs about 1 µs (measured): the small batches of the shooting call such functions
thousands of times per ramp. CasADi's matrices are column-major, so a batch of ``n`` columns of ``rows``
entries is held as an ``(n, rows)`` C-ordered array.
"""

from __future__ import annotations

import threading

import numpy as np


class BufferedFunction:
    """A CasADi function of ``n`` columns bound to preallocated arrays: ``f(*inputs)`` returns a fresh output array.

    Parameters
    ----------
    fun : casadi.Function
        Inputs of ``rows_in[i] × n`` (a row vector for ``rows_in[i] == 1``), one output of ``rows_out × n``.
    rows_in : sequence of int
        Rows of each input.
    rows_out : int
        Rows of the output.
    n : int
        Columns (trajectories).

    Notes
    -----
    A lock makes a call (fill, evaluate, read) atomic, so a model may be shot from several threads.

    Examples
    --------
    >>> import casadi as ca
    >>> x = ca.SX.sym("x", 2)
    >>> f = BufferedFunction(ca.Function("f", [x], [ca.vertcat(x[0] * x[1], x[0] + 1, 2 * x[1])]).map(3), [2], 3, 3)
    >>> f(np.array([[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]])).tolist()
    [[4.0, 10.0, 18.0], [2.0, 3.0, 4.0], [8.0, 10.0, 12.0]]
    """

    def __init__(self, fun, rows_in, rows_out: int, n: int):
        self._inputs = [np.zeros((n, rows)) if rows > 1 else np.zeros(n) for rows in rows_in]
        self._output = np.zeros((n, rows_out))
        self._buffer, self._trigger = fun.buffer()
        for i, a in enumerate(self._inputs):
            self._buffer.set_arg(i, a.data)
        self._buffer.set_res(0, self._output.data)
        self._lock = threading.Lock()

    def __call__(self, *inputs) -> np.ndarray:
        """The output, shape ``(rows_out, n)``, for inputs of shape ``(rows_in[i], n)`` (or ``(n,)``, or scalars)."""
        if len(inputs) != len(self._inputs):
            raise TypeError(f"{len(self._inputs)} inputs expected, {len(inputs)} given")
        with self._lock:
            for a, x in zip(self._inputs, inputs):
                a[...] = x.T if getattr(x, "ndim", 0) == 2 else x
            self._trigger()
            return self._output.T.copy()
