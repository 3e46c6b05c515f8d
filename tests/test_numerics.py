"""Direct tests of the physics-free numerics (:mod:`coexist.numerics`): the vectorised DOP853 integrator,
the CasADi-to-numpy code generator, the splines and the root finders, each on problems with known answers."""

import casadi as ca
import numpy as np
import pytest
from scipy.integrate import DOP853
from scipy.interpolate import CubicSpline, PPoly

from coexist.numerics import dop853 as D
from coexist.numerics.codegen import numpy_function
from coexist.numerics.roots import bisect, bracketed_root, chebyshev_extremum, newton
from coexist.numerics.splines import CubicBundle, FastCubic, casadi_spline, interpolating_cubics, not_a_knot_basis

EPS = np.finfo(float).eps


# ----------------------------------------------------------------------------------------------------------
# DOP853
# ----------------------------------------------------------------------------------------------------------


def decay(t, y):
    """``y' = -k y`` with the rate ``k`` carried as a second, constant state component (the integrator
    hands ``fun`` only the columns still running, so per-column parameters must live in the state)."""
    return np.vstack([-y[1] * y[0], np.zeros_like(y[1])])


def oscillator(t, y):
    """``x'' = -x`` as ``(x, v)' = (v, -x)``."""
    return np.vstack([y[1], -y[0]])


def oscillator_state(t):
    """The oscillator's solution ``(cos t, -sin t)`` (``t`` the time since ``x = 1, v = 0``)."""
    return np.vstack([np.cos(t), -np.sin(t)])


@pytest.mark.parametrize("rtol", [1e-6, 1e-8, 1e-10, 1e-12])
def test_decay_global_error_is_a_few_rtol(rtol):
    """``y' = -k y`` for ``k = 0.5, 1, 2, 4`` in one batch, from ``y = 1`` over ``0 ≤ t ≤ 5`` (up to 20
    decay times), against ``exp(-k t)``.

    Measured: relative global error at most 1.76 rtol (the ``k = 4`` column; the error accumulates
    over the decay times). Asserted: at most 3 rtol in every column, every column at ``t_end`` exactly.
    """
    k = np.array([0.5, 1.0, 2.0, 4.0])
    res = D.integrate(decay, np.zeros(4), np.vstack([np.ones(4), k]), np.full(4, 5.0), rtol, 1e-300, 10_000)
    np.testing.assert_array_equal(res.status, D.REACHED_END)
    np.testing.assert_array_equal(res.t, 5.0)
    error = np.abs(res.y[0] / np.exp(-5.0 * k) - 1.0)
    assert np.all(error <= 3 * rtol), error / rtol
    np.testing.assert_array_equal(res.y[1], k)  # the constant component is untouched


@pytest.mark.parametrize("rtol", [1e-6, 1e-9, 1e-12])
def test_oscillator_global_error_forward_and_backward(rtol):
    """The harmonic oscillator over ``t_end = 0.5, 2, π, 2π`` (four columns), ``atol = rtol``, forwards
    from ``(1, 0)`` and backwards from the exact end state to ``t = 0``.

    Measured: largest error of ``(x, v)`` 1.02 rtol (one full period), backwards the same. Asserted:
    at most 3 rtol both ways, with the trajectories ending at ``t_end`` exactly.
    """
    T = np.array([0.5, 2.0, np.pi, 2 * np.pi])
    start = oscillator_state(np.zeros(4))
    fwd = D.integrate(oscillator, np.zeros(4), start, T, rtol, rtol, 10_000)
    np.testing.assert_array_equal(fwd.status, D.REACHED_END)
    np.testing.assert_array_equal(fwd.t, T)
    assert np.max(np.abs(fwd.y - oscillator_state(T))) <= 3 * rtol
    back = D.integrate(oscillator, T, oscillator_state(T), np.zeros(4), rtol, rtol, 10_000)
    np.testing.assert_array_equal(back.status, D.REACHED_END)
    np.testing.assert_array_equal(back.t, 0.0)
    assert np.max(np.abs(back.y - start)) <= 3 * rtol


def test_fixed_steps_show_eighth_order():
    """Fixed steps (:func:`~coexist.numerics.dop853.single_step` repeated, whatever its error estimate)
    of the oscillator over ``0 ≤ t ≤ 4`` with ``N = 4, 8, 16`` steps, two columns (phases 0 and 1).

    Measured: errors 2.4e-7, 7.9e-10, 2.8e-12; ``log2`` of the error ratios 8.23 and 8.13.
    Asserted: both slopes between 7 and 9 (an 8th-order method).
    """
    phase = np.array([0.0, 1.0])

    def error(n):
        h = 4.0 / n
        t, y = np.zeros(2), oscillator_state(phase)
        for _ in range(n):
            y, _ = D.single_step(oscillator, t, y, np.full(2, h), 1e-10, 1e-10)
            t = t + h
        return np.max(np.abs(y - oscillator_state(phase + 4.0)))

    errors = np.array([error(n) for n in (4, 8, 16)])
    slopes = np.log2(errors[:-1] / errors[1:])
    assert np.all((slopes > 7) & (slopes < 9)), slopes


def test_columns_step_independently():
    """Four decay columns with their own rates and their own rtol (1e-6 … 1e-12), integrated in one
    batch, against each column integrated alone.

    Asserted: the same number of steps per column, and the same end values to 1e-14 relative (the
    columns only share numpy operations, not step sizes).
    """
    k = np.array([0.5, 3.0, 1.0, 2.0])
    rtol = np.array([1e-6, 1e-8, 1e-10, 1e-12])
    y0 = np.vstack([np.ones(4), k])
    together = D.integrate(decay, np.zeros(4), y0, np.full(4, 4.0), rtol, 1e-300, 10_000)
    for j in range(4):
        alone = D.integrate(decay, np.zeros(1), y0[:, j : j + 1], np.full(1, 4.0), rtol[j], 1e-300, 10_000)
        assert together.steps[j] == alone.steps[0]
        np.testing.assert_allclose(together.y[:, j], alone.y[:, 0], rtol=1e-14)
    assert np.all(np.diff(together.steps[[0, 2, 3]]) > 0)  # tighter tolerance, more steps


def test_initial_step_and_step_control_follow_scipy():
    """The starting step of three columns (different scales and rates) against scipy's ``DOP853``, and
    the times after each step of ``y' = -2y`` (rtol 1e-6, atol 1e-12, no rejected step) against scipy
    stepping alone.

    Measured: starting steps equal to 1 ulp; step times equal to 5e-12 relative (scipy combines the stages
    in another order, and the error estimate, a nearly cancelling sum, passes its relative rounding error
    on to the step size through ``err^(-1/8)``). Asserted: 1e-14 and 1e-9 relative, and the same number
    of steps (12) to reach ``t = 5``.
    """
    y0 = np.array([[1.0, 1e3, -0.2], [0.5, 2.0, 7.0]])
    t0 = np.zeros(3)
    f0 = oscillator(t0, y0)
    h = D.initial_step(oscillator, t0, y0, f0, np.ones(3), 1e-8, 1e-10)
    ref = [DOP853(oscillator_rhs_1d, 0.0, y0[:, j], 100.0, rtol=1e-8, atol=1e-10).h_abs for j in range(3)]
    np.testing.assert_allclose(h, ref, rtol=1e-14)

    scipy = DOP853(lambda t, y: -2.0 * y, 0.0, np.array([1.0]), 5.0, rtol=1e-6, atol=1e-12)
    times = []
    while scipy.status == "running":
        scipy.step()
        times.append(scipy.t)
    assert scipy.nfev == 12 * len(times) + 2  # no rejected step: the controllers must agree
    ours = []
    for n in range(1, len(times) + 1):  # stopped after n steps by the step limit
        res = D.integrate(lambda t, y: -2.0 * y, np.zeros(1), np.ones((1, 1)), np.full(1, 5.0), 1e-6, 1e-12, n)
        ours.append(res.t[0])
    assert res.status[0] == D.REACHED_END and len(times) == 12
    np.testing.assert_allclose(ours, times, rtol=1e-9)


def oscillator_rhs_1d(t, y):
    """The oscillator for scipy (one state vector)."""
    return np.array([y[1], -y[0]])


def forced_van_der_pol(t, y):
    """``x'' = (1 - x²) x' - x + sin t``: nonlinear and time-dependent (numpy, many columns)."""
    return np.vstack([y[1], (1 - y[0] ** 2) * y[1] - y[0] + np.sin(t)])


def test_numpy_and_casadi_steppers_agree():
    """One DOP853 step of the forced van der Pol equation for five random states, times and step sizes
    (negative ones included), by :class:`~coexist.numerics.dop853.NumpyStepper` and by the CasADi step
    function (:func:`~coexist.numerics.dop853.casadi_step_function`, mapped and unmapped), and whole
    integrations with both steppers.

    Measured: new states and derivatives equal to 5e-16 relative, error sums to 3e-15 absolute (they are
    cancelling sums of stages of size ~2); integrations with the same steps, end states 1e-15 apart.
    Asserted: 1e-14 relative; 1e-14 times the largest derivative; equal steps and 1e-12.
    """
    t = ca.SX.sym("t")
    y = ca.SX.sym("y", 2)
    rhs = ca.Function("vdp", [t, y], [ca.vertcat(y[1], (1 - y[0] ** 2) * y[1] - y[0] + ca.sin(t))])
    cas = D.CasadiStepper(D.casadi_step_function(rhs, 2), forced_van_der_pol, 2)
    num = D.NumpyStepper(forced_van_der_pol)
    rng = np.random.default_rng(0)
    Y, T, H = rng.uniform(-2, 2, (2, 5)), rng.uniform(0, 3, 5), rng.uniform(-0.3, 0.3, 5)
    F = forced_van_der_pol(T, Y)
    scale = np.max(np.abs(F))
    a, b = num.step(T, Y, F, H), cas.step(T, Y, F, H)
    b1 = cas.step(T[:1], Y[:, :1], F[:, :1], H[:1])  # one column: the unmapped function
    for i, name in enumerate(("y_new", "f_new")):
        np.testing.assert_allclose(b[i], a[i], rtol=1e-14, err_msg=name)
        np.testing.assert_allclose(b1[i], a[i][:, :1], rtol=1e-14, err_msg=name)
    for i, name in ((2, "e5"), (3, "e3")):
        np.testing.assert_allclose(b[i], a[i], rtol=0, atol=1e-14 * scale, err_msg=name)
        np.testing.assert_allclose(b1[i], a[i][:, :1], rtol=0, atol=1e-14 * scale, err_msg=name)
    assert np.max(np.abs(a[2])) > 1e-8  # the error sums are not trivially zero
    r_num = D.integrate(num, np.zeros(5), Y, np.full(5, 10.0), 1e-9, 1e-9, 10_000)
    r_cas = D.integrate(cas, np.zeros(5), Y, np.full(5, 10.0), 1e-9, 1e-9, 10_000)
    np.testing.assert_array_equal(r_num.status, D.REACHED_END)
    np.testing.assert_array_equal(r_cas.steps, r_num.steps)
    np.testing.assert_allclose(r_cas.y, r_num.y, rtol=0, atol=1e-12)


#: the oscillator columns of the event tests: phases (start at ``x = cos φ``) and levels of ``x``
PHASES = np.array([0.0, 0.3, 0.6, 0.9])
LEVELS = np.array([0.5, 0.2, -0.3, 0.3])
#: the times at which ``x`` first falls to its level
CROSSINGS = np.arccos(LEVELS) - PHASES


@pytest.mark.parametrize("rtol", [1e-8, 1e-10, 1e-12])
def test_crossed_event_stops_before_the_level_which_is_then_located(rtol):
    """The oscillator with a ``CROSSED`` event where ``x`` falls to a level of its own per column (the
    event looks the level up by the column indices it is given), then, as the shooting does at the clamp,
    one hop with ``x`` as the independent variable (``dt/dx = 1/v``, ``dv/dx = -x/v``) onto the level.

    Measured: the stopping states (before the discarded step) exact to 0.19 rtol; the crossing times from
    the hop exact to 0.2 rtol. Asserted: stopped with ``CROSSED`` before the crossing, above the level,
    states to 3 rtol; crossing times and ``v`` there to 3 rtol.
    """
    start = oscillator_state(PHASES)

    def event(t, y, columns, f):
        return np.where(y[0] <= LEVELS[columns], D.CROSSED, D.CONTINUE)

    res = D.integrate(oscillator, np.zeros(4), start, np.full(4, 10.0), rtol, rtol, 1000, event=event)
    np.testing.assert_array_equal(res.status, D.CROSSED)
    assert np.all(res.t < CROSSINGS) and np.all(res.y[0] > LEVELS)
    assert np.max(np.abs(res.y - oscillator_state(res.t + PHASES))) <= 3 * rtol

    def hoop(x, z):
        return np.vstack([1.0 / z[1], -x / z[1]])

    z0 = np.vstack([res.t, res.y[1]])
    hop = D.integrate(hoop, res.y[0], z0, LEVELS, rtol, rtol, 1000, h0=0.5 * np.abs(LEVELS - res.y[0]))
    np.testing.assert_array_equal(hop.status, D.REACHED_END)
    assert np.max(np.abs(hop.y[0] - CROSSINGS)) <= 3 * rtol
    assert np.max(np.abs(hop.y[1] + np.sqrt(1 - LEVELS**2))) <= 3 * rtol


def test_failure_code_keeps_the_step_and_step_limit_stops():
    """An event code ``FAILED + 1`` where ``x`` falls to its level: the step is kept and the column stops
    with that code; ``max_steps = 3`` stops every column with ``STEP_LIMIT``.

    Asserted: code 3 everywhere, ``t_previous < crossing ≤ t``, the kept states exact to 3 rtol
    (rtol 1e-10); with the step limit, 3 steps each and ``t`` short of ``t_end``.
    """
    rtol = 1e-10
    start = oscillator_state(PHASES)

    def event(t, y, columns, f):
        return np.where(y[0] <= LEVELS[columns], D.FAILED + 1, D.CONTINUE)

    res = D.integrate(oscillator, np.zeros(4), start, np.full(4, 10.0), rtol, rtol, 1000, event=event)
    np.testing.assert_array_equal(res.status, D.FAILED + 1)
    assert np.all(res.t_previous < CROSSINGS) and np.all(CROSSINGS <= res.t)
    assert np.all(res.y[0] <= LEVELS)
    assert np.max(np.abs(res.y - oscillator_state(res.t + PHASES))) <= 3 * rtol
    assert np.max(np.abs(res.y_previous - oscillator_state(res.t_previous + PHASES))) <= 3 * rtol

    limited = D.integrate(oscillator, np.zeros(4), start, np.full(4, 10.0), rtol, rtol, 3)
    np.testing.assert_array_equal(limited.status, D.STEP_LIMIT)
    np.testing.assert_array_equal(limited.steps, 3)
    assert np.all(limited.t < 10.0)


def test_single_step_error_norm():
    """:func:`~coexist.numerics.dop853.single_step` on the oscillator (rtol = atol = 1e-8): a step of 0.1
    is accepted and exact, a step of 3 is rejected, and a right-hand side that returns NaN gives an
    infinite error.

    Asserted: error norm ≤ 1 and the state to 1e-9; norm > 1; norm inf.
    """
    t, y = np.zeros(2), oscillator_state(np.array([0.0, 1.0]))
    y_new, err = D.single_step(oscillator, t, y, np.array([0.1, -0.1]), 1e-8, 1e-8)
    assert np.all(err <= 1.0)
    np.testing.assert_allclose(y_new, oscillator_state(np.array([0.1, 0.9])), rtol=0, atol=1e-9)
    _, err = D.single_step(oscillator, t, y, np.array([3.0, 3.0]), 1e-8, 1e-8)
    assert np.all(err > 1.0)
    _, err = D.single_step(lambda t, y: np.where(t > 0.05, np.nan, y), t, y, np.full(2, 0.1), 1e-8, 1e-8)
    np.testing.assert_array_equal(err, np.inf)


# ----------------------------------------------------------------------------------------------------------
# codegen
# ----------------------------------------------------------------------------------------------------------

#: every operation the generator translates; :func:`test_generated_code_equals_casadi` covers each
TRANSLATED = {
    "OP_ADD", "OP_SUB", "OP_MUL", "OP_DIV", "OP_POW", "OP_CONSTPOW", "OP_FMIN", "OP_FMAX", "OP_ATAN2",
    "OP_LT", "OP_LE", "OP_EQ", "OP_NE", "OP_COPYSIGN", "OP_HYPOT", "OP_IF_ELSE_ZERO", "OP_NEG", "OP_SQ",
    "OP_TWICE", "OP_INV", "OP_SQRT", "OP_EXP", "OP_LOG", "OP_LOG1P", "OP_EXPM1", "OP_SIN", "OP_COS",
    "OP_TAN", "OP_FABS", "OP_TANH",
}  # fmt: skip
OP_NAMES = {getattr(ca, n): n for n in dir(ca) if n.startswith("OP_")}


def casadi_on_arrays(fun, *args):
    """CasADi's own evaluation of a scalar function on 1-d arrays (mapped over the entries)."""
    n = args[0].size
    out = fun.map(n)(*[np.reshape(a, (1, n)) for a in args])
    return [np.asarray(o).ravel() for o in (out if isinstance(out, (list, tuple)) else [out])]


def test_generated_code_equals_casadi():
    """A three-input function using every translated operation (and constants, negative ones included),
    in numpy from :func:`~coexist.numerics.codegen.numpy_function` (both forms) against CasADi, on 200
    random points (ten of them with ``x = y``, so that ``==`` and ``!=`` take both values).

    Measured: largest relative difference 2.7e-15 (differences of a few ulp, magnified by cancelling
    sums). Asserted: rtol 1e-14, and that the instruction list
    holds every translated operation (so that none goes untested).
    """
    x, y, z = ca.SX.sym("x"), ca.SX.sym("y"), ca.SX.sym("z")
    outs = [
        x + y * z - x / z + x**y + x**2.5 + ca.fmin(x, y) * ca.fmax(y, z) - ca.atan2(y - 1.0, -x),
        (x < y) + (x <= y) + 2.0 * (x == y) - (x != y) + ca.if_else(z < 1.0, x * y, 0),
        ca.copysign(x, y - 1.0) + ca.hypot(x, z) - ca.sqrt(x) + ca.exp(-y) * ca.log(z) + ca.log1p(x),
        ca.expm1(-z) + ca.sin(x) * ca.cos(y) + ca.tan(0.3 * z) + ca.fabs(y - 1.0) + ca.tanh(x - z),
        -(x * y) + (x * z) ** 2 + 2 * (y * z) + 1 / (x + y) + (-3.0) * z,
    ]
    fun = ca.Function("all_ops", [x, y, z], outs)
    ops = {OP_NAMES[fun.instruction_id(k)] for k in range(fun.n_instructions())}
    assert TRANSLATED <= ops, TRANSLATED - ops
    rng = np.random.default_rng(1)
    X, Y, Z = rng.uniform(0.2, 2.0, (3, 200))
    Y[:10] = X[:10]
    ref = casadi_on_arrays(fun, X, Y, Z)
    got = numpy_function(fun)(X, Y, Z)
    into = numpy_function(fun, into=True)(X, Y, Z, np.empty((len(outs), 200)))
    for k in range(len(outs)):
        np.testing.assert_allclose(got[k], ref[k], rtol=1e-14, atol=0, err_msg=f"output {k}")
        np.testing.assert_allclose(into[k], ref[k], rtol=1e-14, atol=0, err_msg=f"output {k} (into)")


def test_comparisons_add_as_numbers_and_negative_bases_keep_their_sign():
    """Comparisons are 0 or 1 in CasADi: ``(x ≤ 1) + (x ≤ 2)`` is 2 at ``x = 0`` (numpy booleans would
    add to True), ``(x < 1) - (x < 2)`` is defined (numpy refuses ``-`` on booleans); a negative constant
    base keeps its sign: ``(-2)^x`` at integer ``x`` is ``-2, 4, -8`` (not ``-(2^x)``).

    Asserted: the generated values equal CasADi's exactly.
    """
    x = ca.SX.sym("x")
    fun = ca.Function("f", [x], [(x <= 1) + (x <= 2), (x < 1) - (x < 2), ca.power(-2.0, x)])
    X = np.array([0.0, 1.0, 2.0, 3.0])
    got = numpy_function(fun)(X)
    ref = casadi_on_arrays(fun, X)
    np.testing.assert_array_equal(got[0], [2.0, 2.0, 1.0, 0.0])
    np.testing.assert_array_equal(got[1], [0.0, -1.0, 0.0, 0.0])
    np.testing.assert_array_equal(got[2], [1.0, -2.0, 4.0, -8.0])
    for k in range(3):
        np.testing.assert_array_equal(got[k], ref[k])


@pytest.mark.parametrize("into", [False, True])
def test_constant_outputs_take_the_input_shape(into):
    """Outputs that are constants (2.0, 0, ``inf``, ``-inf``, ``nan``) next to one that depends on the
    inputs, called with arrays of 7 points.

    Asserted: each output has shape (7,) and the exact constant value. (Before the fix the generator
    wrote ``inf`` and ``nan`` as bare names: NameError; and took ``inf`` for a variable by its first
    letter, so it would not have been broadcast.)
    """
    x, y = ca.SX.sym("x"), ca.SX.sym("y")
    consts = [2.0, 0.0, np.inf, -np.inf]
    fun = ca.Function("f", [x, y], [x * y] + [ca.SX(c) for c in consts] + [ca.SX(np.nan)])
    X, Y = np.linspace(0.0, 1.0, 7), np.linspace(1.0, 2.0, 7)
    gen = numpy_function(fun, into=into)
    out = gen(X, Y, np.empty((6, 7))) if into else gen(X, Y)
    assert len(out) == 6 and all(np.shape(o) == (7,) for o in out)
    np.testing.assert_array_equal(out[0], X * Y)
    for k, c in enumerate(consts, start=1):
        np.testing.assert_array_equal(out[k], np.full(7, c))
    assert np.all(np.isnan(out[5]))


def test_infinite_constants_inside_expressions():
    """``inf`` as an operand: ``x·y + inf``, ``exp(-inf·x)`` and ``atan2(x, inf)`` for ``x > 0``.

    Asserted: ``inf``, 0 and ``atan2(x, inf) = 0`` as CasADi computes them, exactly.
    """
    x, y = ca.SX.sym("x"), ca.SX.sym("y")
    fun = ca.Function("f", [x, y], [x * y + ca.inf, ca.exp(-ca.inf * x), ca.atan2(x, ca.inf)])
    X, Y = np.array([0.5, 1.0, 3.0]), np.array([1.0, -2.0, 4.0])
    got = numpy_function(fun)(X, Y)
    ref = casadi_on_arrays(fun, X, Y)
    for k, value in enumerate([np.inf, 0.0, 0.0]):
        np.testing.assert_array_equal(got[k], np.full(3, value))
        np.testing.assert_array_equal(ref[k], np.full(3, value))


@pytest.mark.parametrize(
    "expr, name",
    [
        (lambda x, y: ca.asin(x) + y, "OP_ASIN"),
        (lambda x, y: ca.fmod(2.0, x) * ca.sin(y), "OP_FMOD"),  # once folded to the constant 0 silently
        (lambda x, y: ca.if_else(x < y, x, y), "OP_NOT"),
        (lambda x, y: ca.floor(x * y), "OP_FLOOR"),
    ],
)
def test_unsupported_operations_raise_naming_the_operation(expr, name):
    """Operations without a numpy translation (with variable operands) raise NotImplementedError whose
    message names the CasADi operation and the function; none is turned into code."""
    x, y = ca.SX.sym("x"), ca.SX.sym("y")
    fun = ca.Function("unsupported", [x, y], [expr(x, y)])
    with pytest.raises(NotImplementedError, match=f"{name} in unsupported"):
        numpy_function(fun)


def test_non_scalar_input_is_refused():
    """The generator handles scalar inputs only: a 2-vector input raises ValueError naming it."""
    x = ca.SX.sym("x", 2)
    with pytest.raises(ValueError, match="input i0 of f is not scalar"):
        numpy_function(ca.Function("f", [x], [x[0] * x[1]]))


# ----------------------------------------------------------------------------------------------------------
# splines
# ----------------------------------------------------------------------------------------------------------

#: a nonuniform grid on [0, 2] (random interior points; smallest interval 4 % of the largest)
GRID = np.sort(np.concatenate([[0.0, 2.0], np.random.default_rng(3).uniform(0.0, 2.0, 9)]))


def test_fast_cubic_equals_ppoly():
    """:class:`~coexist.numerics.splines.FastCubic` of a not-a-knot spline through ``sin 3x``, and its first
    three derivatives, against scipy's ``PPoly`` at 501 points on ``[-0.7, 2.8]`` (beyond both ends) and at
    the breakpoints themselves.

    Measured: 1.3e-15 absolute (values up to 3.9). Asserted: 1e-14 times the largest value of each.
    """
    spline = CubicSpline(GRID, np.sin(3 * GRID))
    fast = FastCubic(spline)
    u = np.concatenate([np.linspace(-0.7, 2.8, 501), GRID])
    for order in range(4):
        ref = spline.derivative(order)(u) if order else spline(u)
        got = fast(u)
        np.testing.assert_allclose(got, ref, rtol=0, atol=1e-14 * np.max(np.abs(ref)), err_msg=f"order {order}")
        fast = fast.derivative()
    assert abs(float(FastCubic(spline)(0.3)) - float(spline(0.3))) <= 4 * EPS  # scalar argument


def test_interpolating_cubics_equal_cubic_spline():
    """:func:`~coexist.numerics.splines.interpolating_cubics` for four columns (``sin 3x``, ``eˣ``,
    ``x³ − x``, random data) on the nonuniform grid, against ``CubicSpline(x, y)`` (not-a-knot) per column:
    values and slopes at 801 points of the grid's span, and the nodes.

    Measured: 2e-14 of the data's scale (values), 1.2e-13 (slopes); not asserted: beyond the grid the
    cubic extrapolation magnifies the rounding of the coefficients, to 1.7e-12 at 0.3 of the span.
    Asserted: 1e-13 and 1e-12 of the largest value; and the basis is computed once per grid.
    """
    rng = np.random.default_rng(4)
    Y = np.column_stack([np.sin(3 * GRID), np.exp(GRID), GRID**3 - GRID, rng.normal(size=GRID.size)])
    splines = interpolating_cubics(GRID, Y)
    assert len(splines) == 4
    u = np.linspace(GRID[0], GRID[-1], 801)
    for j, s in enumerate(splines):
        ref = CubicSpline(GRID, Y[:, j])
        np.testing.assert_allclose(s(u), ref(u), rtol=0, atol=1e-13 * np.max(np.abs(Y[:, j])), err_msg=f"{j}")
        slope = ref.derivative()(u)
        np.testing.assert_allclose(
            s.derivative()(u), slope, rtol=0, atol=1e-12 * np.max(np.abs(slope)), err_msg=f"slope {j}"
        )
        np.testing.assert_allclose(s(GRID), Y[:, j], rtol=0, atol=1e-13 * np.max(np.abs(Y[:, j])))
    basis = not_a_knot_basis(GRID)
    assert basis.shape == (4, GRID.size - 1, GRID.size)
    assert not_a_knot_basis(GRID.copy()) is basis


def test_cubic_bundle_equals_its_splines_and_their_derivatives():
    """:class:`~coexist.numerics.splines.CubicBundle` of two not-a-knot cubics against each spline and its first two
    derivatives (:meth:`FastCubic.derivative`), at 3 points (the float path) and at 301 points on ``[-0.7, 2.8]``
    (the numpy path, beyond both ends too); splines on different grids are refused.

    Measured: equal to the last bit on both paths (the same arithmetic). Asserted: 4 ulp of the largest value.
    """
    a, b = interpolating_cubics(GRID, np.column_stack([np.sin(3 * GRID), np.exp(GRID)]))
    bundle = CubicBundle((a, b))
    for u in (np.array([-0.2, 0.37, 2.6]), np.linspace(-0.7, 2.8, 301)):
        got = bundle(u)
        for j, s in enumerate((a, b)):
            for order in range(3):
                ref = s(u) if order == 0 else (s.derivative() if order == 1 else s.derivative().derivative())(u)
                np.testing.assert_allclose(got[order][j], ref, rtol=0, atol=4 * EPS * np.max(np.abs(ref)))
    other = interpolating_cubics(GRID * 1.1, np.column_stack([GRID]))[0]
    with pytest.raises(ValueError, match="one grid"):
        CubicBundle((a, other))


def test_casadi_spline_and_its_window():
    """:func:`~coexist.numerics.splines.casadi_spline` as a CasADi function: the whole spline against
    scipy at 501 points on ``[-0.7, 2.8]``; with ``window=(3, 6)`` (pieces 3 to 6) the spline inside the
    window, and outside it the window's end pieces extended (not the spline).

    Measured: 1.3e-15 and 2.2e-16 absolute. Asserted: 1e-14 times the largest value; outside the window
    the extended pieces to 1e-14 and visibly not the spline (differences above 1e-3).
    """
    spline = CubicSpline(GRID, np.sin(3 * GRID))
    u = np.linspace(-0.7, 2.8, 501)
    scale = np.max(np.abs(spline(u)))
    x = ca.SX.sym("x")

    def evaluate(window):
        fun = ca.Function("s", [x], [casadi_spline(FastCubic(spline), x, window)])
        return np.asarray(fun.map(u.size)(u[None, :])).ravel()

    np.testing.assert_allclose(evaluate(None), spline(u), rtol=0, atol=1e-14 * scale)
    first, last = 3, 6
    a, b = GRID[first], GRID[last + 1]
    values = evaluate((first, last))
    inside = (u >= a) & (u <= b)
    np.testing.assert_allclose(values[inside], spline(u[inside]), rtol=0, atol=1e-14 * scale)
    below = PPoly(spline.c[:, first : first + 1], GRID[first : first + 2])
    above = PPoly(spline.c[:, last : last + 1], GRID[last : last + 2])
    np.testing.assert_allclose(values[u < a], below(u[u < a]), rtol=0, atol=1e-14 * scale)
    np.testing.assert_allclose(values[u > b], above(u[u > b]), rtol=0, atol=1e-14 * scale)
    assert np.max(np.abs(values[u > b] - spline(u[u > b]))) > 1e-3


# ----------------------------------------------------------------------------------------------------------
# roots
# ----------------------------------------------------------------------------------------------------------


def test_bracketed_root_solves_many_problems_at_once():
    """Cube roots of 0.5, 2, 8, 27, 100 in one call, each with its own bracket (``f`` looks its constant up
    by the problem indices it is given), with the brackets as given and reversed (``lo > hi``).

    Measured: errors at most 1 ulp (8.9e-16). Asserted: all converged, error ≤ 1e-14 (the ``xtol``);
    every evaluation asks only for open problems.
    """
    c = np.array([0.5, 2.0, 8.0, 27.0, 100.0])
    lo = np.array([0.0, 0.5, 1.0, -1.0, 0.0])
    hi = np.array([1.0, 3.0, 2.5, 4.0, 10.0])
    sizes = []

    def f(x, idx):
        sizes.append(idx.size)
        return x**3 - c[idx]

    for a, b in ((lo, hi), (hi, lo)):
        sizes.clear()
        res = bracketed_root(f, a, b, xtol=1e-14)
        assert res.converged.all()
        np.testing.assert_allclose(res.x, np.cbrt(c), rtol=0, atol=1e-14)
        assert sizes[:2] == [5, 5] and sizes == sorted(sizes, reverse=True)


def test_bracketed_root_is_superlinear():
    """Iterations of the Illinois method to ``xtol = 1e-14``: ``cos x = x`` on ``[0, 1]`` and ``eˣ = 1.5 +
    sin x`` on ``[-1, 3]``, against bisection's ``log2(width / xtol)`` (47 and 49).

    Measured: 7 and 15 iterations. Asserted: at most 10 and 20, roots to 1e-14.
    """
    r = bracketed_root(lambda x, _: np.cos(x) - x, 0.0, 1.0, xtol=1e-14)
    assert r.converged[0] and r.iterations <= 10 < np.log2(1.0 / 1e-14)
    assert abs(r.x[0] - 0.7390851332151607) <= 1e-14
    r = bracketed_root(lambda x, _: np.exp(x) - 1.5 - np.sin(x), -1.0, 3.0, xtol=1e-14)
    assert r.converged[0] and r.iterations <= 20 < np.log2(4.0 / 1e-14)
    assert abs(np.exp(r.x[0]) - 1.5 - np.sin(r.x[0])) <= 1e-14 and r.width[0] <= 1e-14


def test_bracketed_root_nan_is_the_hi_side_and_inf_counts_by_sign():
    """``√(2 − x) − 0.5`` on ``[0, 5]`` (NaN beyond 2, the hi end included), ``1.2 − x`` replaced by NaN
    beyond 1.3 on ``[0, 3]``, and a function that is ``+inf`` left of 0.7 and ``0.75 − x`` right of it.

    Asserted: all converge, to 1.75, 1.2 and 0.75 within 1e-13.
    """

    def sqrt_minus(x, _):
        with np.errstate(invalid="ignore"):
            return np.sqrt(2.0 - x) - 0.5

    r = bracketed_root(sqrt_minus, 0.0, 5.0, xtol=1e-13)
    assert r.converged[0] and abs(r.x[0] - 1.75) <= 1e-13
    r = bracketed_root(lambda x, _: np.where(x <= 1.3, 1.2 - x, np.nan), 0.0, 3.0, xtol=1e-13)
    assert r.converged[0] and abs(r.x[0] - 1.2) <= 1e-13
    r = bracketed_root(lambda x, _: np.where(x < 0.7, np.inf, 0.75 - x), 0.0, 1.0, xtol=1e-13)
    assert r.converged[0] and abs(r.x[0] - 0.75) <= 1e-13


def test_bracketed_root_without_sign_change_raises():
    """Two problems, ``x² − 0.5`` on ``[0, 1]`` (a root) and ``x² + 1`` on ``[0, 2]`` (none): ValueError
    naming the second bracket and the values at its ends."""
    c = np.array([-0.5, 1.0])
    with pytest.raises(ValueError, match=r"no sign change on \[0, 2\] \(f = 1, 5\)"):
        bracketed_root(lambda x, idx: x**2 + c[idx], [0.0, 0.0], [1.0, 2.0])


def test_bracketed_root_nan_at_lo_is_refused():
    """The lower end must be a valid point: ``f(lo) = NaN`` raises ValueError naming it (before the fix it
    "converged" next to ``lo`` with ``f = NaN``); so does a function that is NaN everywhere."""
    with pytest.raises(ValueError, match="NaN at the lower end"):
        bracketed_root(lambda x, _: np.where(x < 0.2, np.nan, 0.55 - x), 0.0, 1.0, xtol=1e-13)
    with pytest.raises(ValueError, match="NaN at the lower end"):
        bracketed_root(lambda x, _: np.full_like(x, np.nan), 0.0, 1.0, xtol=1e-13)


def test_bisect():
    """:func:`~coexist.numerics.roots.bisect` of ``x² < 2`` on ``[0, 2]`` and of ``x² > 2`` on the reversed
    bracket ``[2, 0]``; a predicate that answers None stops at once.

    Asserted: brackets around √2 no wider than 1e-12 and decided; with None, the original bracket, one
    evaluation, and ``decided`` False.
    """
    lo, hi, decided = bisect(lambda x: x * x < 2.0, 0.0, 2.0, xtol=1e-12)
    assert decided and lo < np.sqrt(2) < hi and hi - lo <= 1e-12
    lo, hi, decided = bisect(lambda x: x * x > 2.0, 2.0, 0.0, xtol=1e-12)
    assert decided and hi < np.sqrt(2) < lo and lo - hi <= 1e-12
    calls = []
    lo, hi, decided = bisect(lambda x: calls.append(x), 0.0, 2.0, xtol=1e-12)
    assert (lo, hi, decided) == (0.0, 2.0, False) and calls == [1.0]


def test_newton_bracket_rescues_a_bad_start():
    """``arctan(x − r)`` for ``r = 0.3, −1, 2`` from 3, 2.5 and 4 away from the root, where plain Newton's
    first step lands 9.5, 6.1 and 18.5 away (outside the bracket ``[r − 5, r + 6]``, and diverging), with
    the bracket and ``sign_at_lo = −1``, and with the bracket reversed (``sign_at_lo = +1``).

    Measured: 7 iterations, errors at most 1.3e-14. Asserted: converged in at most 10, error ≤ 1e-13.
    """
    r0 = np.array([0.3, -1.0, 2.0])
    x0 = r0 + np.array([3.0, -2.5, 4.0])
    d = x0 - r0
    first = x0 - np.arctan(d) * (1 + d**2)
    assert np.all((first < r0 - 5) | (first > r0 + 6))

    def f(x, idx):
        return np.arctan(x - r0[idx]), 1.0 / (1.0 + (x - r0[idx]) ** 2)

    for lo, hi, sign in ((r0 - 5, r0 + 6, -1.0), (r0 + 6, r0 - 5, 1.0)):
        res = newton(f, x0, xtol=1e-13, lo=lo, hi=hi, sign_at_lo=sign, max_iter=50)
        assert res.converged.all() and res.iterations <= 10
        np.testing.assert_allclose(res.x, r0, rtol=0, atol=1e-13)


def test_newton_stops_when_stalled_on_noise():
    """``x² − c`` (``c = 2, 3, 10``) with noise of 1e-12 (seeded normal) added to ``f``, from ``x = 1``,
    ``xtol = 1e-16`` (below the noise's step of ~3e-13): with ``stop_when_stalled`` the iteration stops,
    converged, once a step no longer halves; without it, it wanders to ``max_iter``.

    Measured: stalled after 8 iterations, errors ≤ 2.6e-13. Asserted: converged, at most 20 iterations,
    error ≤ 1e-11; without the stall test ``converged`` False after 40 iterations.
    """
    c = np.array([2.0, 3.0, 10.0])

    def noisy(rng):
        def f(x, idx):
            return x**2 - c[idx] + 1e-12 * rng.standard_normal(x.size), 2 * x

        return f

    res = newton(noisy(np.random.default_rng(0)), np.ones(3), xtol=1e-16, max_iter=40)
    assert res.converged.all() and res.iterations <= 20
    np.testing.assert_allclose(res.x, np.sqrt(c), rtol=0, atol=1e-11)
    res = newton(noisy(np.random.default_rng(0)), np.ones(3), xtol=1e-16, max_iter=40, stop_when_stalled=False)
    assert not res.converged.any() and res.iterations == 40


def test_chebyshev_extremum_finds_maxima_and_minima():
    """Extrema of ``sin`` on four brackets at once (maxima at π/2 and 5π/2, minima at 3π/2 and 7π/2), the
    maximum of ``x e⁻ˣ`` (1 at ``x = 1``, ``e⁻¹``) and the minimum of ``cosh(x − 0.37)``, ``ftol = 1e-12``.

    Measured: values to 4e-15, locations to 1e-12 (sin), 7e-13 and 7e-14. Asserted: values to ftol,
    locations to 1e-6 (the value fixes the location only to about √ftol).
    """
    lo, hi = np.array([1.0, 4.0, 7.0, 10.5]), np.array([2.0, 5.5, 8.5, 11.5])
    x, g = chebyshev_extremum(np.sin, lo, hi, [True, False, True, False], ftol=1e-12, xtol=1e-12)
    np.testing.assert_allclose(x, np.pi * np.array([0.5, 1.5, 2.5, 3.5]), rtol=0, atol=1e-6)
    np.testing.assert_allclose(g, [1.0, -1.0, 1.0, -1.0], rtol=0, atol=1e-12)
    x, g = chebyshev_extremum(lambda x: x * np.exp(-x), [0.2], [3.0], [True], ftol=1e-12, xtol=1e-12)
    assert abs(x[0] - 1.0) <= 1e-6 and abs(g[0] - np.exp(-1.0)) <= 1e-12
    x, g = chebyshev_extremum(lambda x: np.cosh(x - 0.37), [-1.0], [2.0], [False], ftol=1e-12, xtol=1e-12)
    assert abs(x[0] - 0.37) <= 1e-6 and abs(g[0] - 1.0) <= 1e-12


def test_chebyshev_extremum_refuses_non_finite_values():
    """A function that is NaN only in the third of four brackets raises ValueError naming that bracket."""

    def g(x):
        return np.where(np.abs(x - 7.75) < 0.5, np.nan, np.sin(x))

    lo, hi = np.array([1.0, 4.0, 7.0, 10.5]), np.array([2.0, 5.5, 8.5, 11.5])
    with pytest.raises(ValueError, match=r"not finite in \[7, 8.5\]"):
        chebyshev_extremum(g, lo, hi, [True, False, True, False], ftol=1e-12, xtol=1e-12)


def test_the_dop853_tableau_is_scipys_to_the_last_bit():
    """The copied tableau (so the integrator need not import scipy.integrate) equals SciPy's exactly."""
    from scipy.integrate import DOP853

    from coexist.numerics import dop853_tableau as T

    assert T.N_STAGES == DOP853.n_stages
    assert np.array_equal(T.A, DOP853.A[: T.N_STAGES, : T.N_STAGES])
    assert np.array_equal(T.B, DOP853.B)
    assert np.array_equal(T.C, DOP853.C[: T.N_STAGES])
    assert np.array_equal(T.E3, DOP853.E3)
    assert np.array_equal(T.E5, DOP853.E5)


# --- rosenbrock2 (the stiff integrator of the jumps' gradient flow) -----------------------------------


def test_rosenbrock2_is_stable_on_a_stiff_system_and_second_order_on_a_smooth_one():
    """``u' = A u`` with eigenvalues −1 and −1e6 (stiffness 1e6): the end state at ``t = 2`` agrees with
    the matrix exponential within a few times the tolerance asked for, in a few thousand steps where an
    explicit method's stability limit (``h < 2e-6``) needs a million. On the non-stiff ``A`` (a Jordan
    block at −1) the error falls by ~30× per 10× in tolerance (order 2: ``tol^{3/2}``)."""
    from scipy.linalg import expm

    from coexist.numerics.stiff import rosenbrock2

    u0 = np.array([1.0, 1.0])
    stiff = np.array([[-1.0, 1.0], [0.0, -1e6]])
    exact = expm(2.0 * stiff) @ u0
    for rtol in (1e-3, 1e-4):
        r = rosenbrock2(lambda t, u: stiff @ u, u0, 2.0, rtol=rtol, atol=1e-10)
        assert r.status == "t_end" and r.t == pytest.approx(2.0, abs=1e-12)
        assert r.steps < 5000
        assert abs(r.u[0] - exact[0]) / abs(exact[0]) < 5 * rtol
        assert abs(r.u[1]) < 1e-10
    smooth = np.array([[-1.0, 1.0], [0.0, -1.0]])
    exact = expm(2.0 * smooth) @ u0
    errors = []
    for rtol in (1e-4, 1e-5, 1e-6):
        r = rosenbrock2(lambda t, u: smooth @ u, u0, 2.0, rtol=rtol, atol=1e-12)
        errors.append(abs(r.u[0] - exact[0]) / abs(exact[0]))
    assert errors[-1] < 1e-8
    assert errors[0] / errors[1] > 15 and errors[1] / errors[2] > 15


def test_rosenbrock2_locates_a_terminal_event():
    """``u' = −u`` from 1: the event ``u = 0.5`` is at ``t = ln 2``, located to the step's interpolant."""
    from coexist.numerics.stiff import rosenbrock2

    r = rosenbrock2(lambda t, u: -u, [1.0], 50.0, events=[lambda t, u: 1.0, lambda t, u: u[0] - 0.5], rtol=1e-8)
    assert r.status == "event" and r.event == 1
    assert r.u[0] == pytest.approx(0.5, abs=1e-9)
    assert r.t == pytest.approx(np.log(2.0), rel=1e-5)


def test_rosenbrock2_follows_a_gradient_flow_into_the_basin_it_starts_in():
    """The double well ``G = (u² − 1)²/4``, ``u' = −G'(u)``: from just either side of the saddle ``u = 0`` the
    flow ends in the well on that side (the basin decision the ramp's jumps rely on)."""
    from coexist.numerics.stiff import rosenbrock2

    for start, well in ((1e-6, 1.0), (-1e-6, -1.0)):
        r = rosenbrock2(lambda t, u: -(u**3 - u), [start], 1e4, rtol=1e-4, atol=1e-7)
        assert r.u[0] == pytest.approx(well, abs=1e-5)


# --- FastCubic.roots without scipy ----------------------------------------------------------------------


def test_fast_cubic_roots_of_a_derivative_equal_scipys():
    """Roots of the derivative of a not-a-knot spline (closed-form quadratic pieces) against scipy's
    ``PPoly.roots``, inside the grid and extrapolated; a cubic's roots (through scipy) too."""
    from scipy.interpolate import CubicSpline

    x = np.linspace(0.0, 3.0, 41)
    for y in (np.sin(3 * x), np.cos(5 * x) + 0.1 * x, (x - 1.5) ** 2 - 0.25):
        ref = CubicSpline(x, y)
        (fast,) = interpolating_cubics(x, y[:, None])
        for extrapolate in (False, True):
            want = ref.derivative().roots(extrapolate=extrapolate)
            got = fast.derivative().roots(extrapolate=extrapolate)
            # (a linear piece's rounding-sized quadratic term puts a root at 1e12: not a root worth comparing)
            want = np.unique(want[np.isfinite(want) & (np.abs(want) < 100)])
            got = got[np.abs(got) < 100]
            assert got.shape == want.shape
            np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)
        np.testing.assert_allclose(fast.roots(), ref.roots(extrapolate=False), rtol=0, atol=1e-12)


def test_chebyshev_extremum_stops_after_one_round_when_the_interpolant_is_resolved():
    """On a narrow bracket (a curve's grid spacing) the degree-8 interpolant of ``sin`` is resolved: one
    call of ``g``, the maximum located to 1e-10; on a wide bracket it is not, and more rounds follow to
    the same accuracy. An extremum near the edge of resolution (``cos(40x)``) is still right."""
    from coexist.numerics.roots import chebyshev_extremum

    for lo, hi, rounds in ((1.55, 1.60, 1), (0.2, 3.0, 2)):
        calls = []

        def g(x, calls=calls):
            calls.append(x.size)
            return np.sin(x)

        x, v = chebyshev_extremum(g, [lo], [hi], [True], ftol=1e-14, xtol=1e-10)
        assert abs(x[0] - np.pi / 2) <= 1e-10 and abs(v[0] - 1.0) <= 1e-14
        assert (len(calls) == 1) if rounds == 1 else (len(calls) >= 2)
    x, v = chebyshev_extremum(lambda x: np.cos(40 * x), [-0.05], [0.06], [True], ftol=1e-14, xtol=1e-12)
    assert abs(x[0]) <= 1e-10 and abs(v[0] - 1.0) <= 1e-14
