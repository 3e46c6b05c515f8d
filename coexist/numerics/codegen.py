"""Turn a CasADi SX function into plain numpy code.

The physics is written once, symbolically, with CasADi (exact derivatives, common subexpressions
eliminated by CasADi). Evaluating a CasADi function on arrays of a few hundred states costs more in
call overhead than the arithmetic itself, so the hot path uses numpy code generated from the same
expression graph: :func:`numpy_function` walks the SX algorithm instruction by instruction and
emits one numpy statement per instruction. The generated function is tested against CasADi's own
evaluation (``tests/test_model.py``).
"""

from __future__ import annotations

import casadi as ca
import numpy as np

_BINARY = {
    ca.OP_ADD: "{0} + {1}",
    ca.OP_SUB: "{0} - {1}",
    ca.OP_MUL: "{0} * {1}",
    ca.OP_DIV: "{0} / {1}",
    ca.OP_POW: "{0} ** {1}",
    ca.OP_CONSTPOW: "{0} ** {1}",
    ca.OP_FMIN: "_np.minimum({0}, {1})",
    ca.OP_FMAX: "_np.maximum({0}, {1})",
    ca.OP_ATAN2: "_np.arctan2({0}, {1})",
    # comparisons are 0.0 or 1.0 in CasADi: numpy booleans would add as `or` (True + True == True)
    ca.OP_LT: "1.0 * ({0} < {1})",
    ca.OP_LE: "1.0 * ({0} <= {1})",
    ca.OP_EQ: "1.0 * ({0} == {1})",
    ca.OP_NE: "1.0 * ({0} != {1})",
    ca.OP_COPYSIGN: "_np.copysign({0}, {1})",
    ca.OP_HYPOT: "_np.hypot({0}, {1})",
    ca.OP_IF_ELSE_ZERO: "_np.where({0}, {1}, 0.0)",
}
_UNARY = {
    ca.OP_NEG: "-{0}",
    ca.OP_SQ: "{0} * {0}",
    ca.OP_TWICE: "2.0 * {0}",
    ca.OP_INV: "1.0 / {0}",
    ca.OP_SQRT: "_np.sqrt({0})",
    ca.OP_EXP: "_np.exp({0})",
    ca.OP_LOG: "_np.log({0})",
    ca.OP_LOG1P: "_np.log1p({0})",
    ca.OP_EXPM1: "_np.expm1({0})",
    ca.OP_SIN: "_np.sin({0})",
    ca.OP_COS: "_np.cos({0})",
    ca.OP_TAN: "_np.tan({0})",
    ca.OP_FABS: "_np.abs({0})",
    ca.OP_TANH: "_np.tanh({0})",
    ca.OP_ASSIGN: "{0}",
}
#: the same instructions on Python floats (:func:`numpy_source` with ``scalar=True``): ``math`` raises where numpy
#: returns NaN or infinity (a negative square root, a division by zero, an overflowing exponential), and
#: :func:`small_batch` then falls back to the numpy code, so both give the same numbers
_SCALAR_BINARY = {
    **_BINARY,
    ca.OP_POW: "_m.pow({0}, {1})",
    ca.OP_CONSTPOW: "_m.pow({0}, {1})",
    ca.OP_FMIN: "_fmin({0}, {1})",
    ca.OP_FMAX: "_fmax({0}, {1})",
    ca.OP_ATAN2: "_m.atan2({0}, {1})",
    ca.OP_COPYSIGN: "_m.copysign({0}, {1})",
    ca.OP_HYPOT: "_m.hypot({0}, {1})",
    ca.OP_IF_ELSE_ZERO: "({1} if {0} else 0.0)",
}
_SCALAR_UNARY = {
    **_UNARY,
    ca.OP_SQRT: "_m.sqrt({0})",
    ca.OP_EXP: "_m.exp({0})",
    ca.OP_LOG: "_m.log({0})",
    ca.OP_LOG1P: "_m.log1p({0})",
    ca.OP_EXPM1: "_m.expm1({0})",
    ca.OP_SIN: "_m.sin({0})",
    ca.OP_COS: "_m.cos({0})",
    ca.OP_TAN: "_m.tan({0})",
    ca.OP_FABS: "abs({0})",
    ca.OP_TANH: "_m.tanh({0})",
}
#: what the scalar code needs besides ``math``: NaN-propagating minimum and maximum (as numpy's)
_SCALAR_HELPERS = """import math as _m


def _fmin(a, b):
    return a if a <= b else (b if b < a else _m.nan)


def _fmax(a, b):
    return a if a >= b else (b if b > a else _m.nan)
"""
#: CasADi's operation codes by name, for error messages
_OP_NAMES = {getattr(ca, n): n for n in dir(ca) if n.startswith("OP_")}


def _literal(value: float, lib: str = "_np") -> str:
    """A float constant as Python source: ``inf`` and ``nan`` through numpy (or ``math``: ``lib="_m"``), negatives
    in parentheses (``(-2.0) ** x``, not ``-(2.0 ** x)``)."""
    if not np.isfinite(value):
        return f"{lib}.nan" if np.isnan(value) else (f"{lib}.inf" if value > 0 else f"(-{lib}.inf)")
    return f"({value!r})" if np.signbit(value) else repr(value)


def numpy_source(fun: ca.Function, name: str = "generated", into: bool = False, scalar: bool = False) -> str:
    """Python source of a numpy function equivalent to a scalar-input CasADi SX function.

    Every input and output of ``fun`` must be a scalar (1x1); the generated function takes one
    array (or float) per input, broadcasts them, and returns a tuple with one array per output.

    Parameters
    ----------
    fun : casadi.Function
        The function; an MX function is expanded to SX first, and common subexpressions are eliminated.
    name : str, optional
        The name of the generated ``def`` (default ``"generated"``).
    into : bool, optional
        Generate ``name(i0, …, out)``, which writes output ``k`` into ``out[k]`` and returns ``out``
        (default False: return a new tuple; a constant output is broadcast to the inputs' shape).
    scalar : bool, optional
        Generate the same statements on Python floats (``math`` for the functions; returns a tuple of floats;
        ``into`` is ignored): for a few states at a time, where each numpy operation costs a microsecond of
        overhead and a float operation some 50 ns (:func:`small_batch`). It needs :data:`_SCALAR_HELPERS`.

    Returns
    -------
    str
        The source of one function, one numpy statement per CasADi instruction, constants folded; it
        refers to numpy as ``_np`` (the scalar form to ``math`` as ``_m``).

    Raises
    ------
    ValueError
        If an input or output of ``fun`` is not scalar.
    NotImplementedError
        If ``fun`` uses a CasADi operation without a numpy translation.
    """
    if not fun.is_a("SXFunction"):
        fun = fun.expand()
    fun = _eliminate_common_subexpressions(fun)
    for i in range(fun.n_in()):
        if fun.nnz_in(i) != 1:
            raise ValueError(f"input {fun.name_in(i)} of {fun.name()} is not scalar")
    for i in range(fun.n_out()):
        if fun.nnz_out(i) != 1:
            raise ValueError(f"output {fun.name_out(i)} of {fun.name()} is not scalar")
    args = [f"i{i}" for i in range(fun.n_in())]
    body = []
    slot: dict = {}  # CasADi work slot -> ("const", value) or ("var", name)
    outputs = [("const", 0.0)] * fun.n_out()

    lib = "_m" if scalar else "_np"
    binary, unary = (_SCALAR_BINARY, _SCALAR_UNARY) if scalar else (_BINARY, _UNARY)

    def source(entry):
        kind, value = entry
        return _literal(value, lib) if kind == "const" else value

    def ref(k):
        return source(slot[k])

    for k in range(fun.n_instructions()):
        op = fun.instruction_id(k)
        ins = fun.instruction_input(k)
        outs = fun.instruction_output(k)
        if op == ca.OP_INPUT:
            slot[outs[0]] = ("var", f"i{ins[0]}")
            continue
        if op == ca.OP_OUTPUT:
            outputs[outs[0]] = slot[ins[0]]
            continue
        if op == ca.OP_CONST:
            slot[outs[0]] = ("const", float(fun.instruction_constant(k)))
            continue
        if op == ca.OP_ASSIGN:
            slot[outs[0]] = slot[ins[0]]
            continue
        operands = [slot[i] for i in ins]  # one input for a unary operation, two for a binary one
        if all(kind == "const" for kind, _ in operands):
            # fold constants at generation time with CasADi's own arithmetic
            slot[outs[0]] = ("const", _fold(op, [v for _, v in operands]))
            continue
        if op in (ca.OP_MUL,) and ("const", 1.0) in operands:
            slot[outs[0]] = operands[1] if operands[0] == ("const", 1.0) else operands[0]
            continue
        if op in (ca.OP_ADD,) and ("const", 0.0) in operands:
            slot[outs[0]] = operands[1] if operands[0] == ("const", 0.0) else operands[0]
            continue
        var = f"v{k}"
        template = (binary if len(ins) == 2 else unary).get(op)
        if template is None:
            raise NotImplementedError(
                f"CasADi operation {_OP_NAMES.get(op, op)} in {fun.name()} has no numpy translation"
            )
        body.append(f"    {var} = " + template.format(*[ref(i) for i in ins]))
        slot[outs[0]] = ("var", var)
    if scalar:
        lines = [f"def {name}({', '.join(args)}):"] + body
        lines.append("    return (" + "".join(f"{source(o)}, " for o in outputs) + ")")
        return "\n".join(lines) + "\n"
    if into:
        # write output k into row k of a caller's array (no temporaries for the result)
        lines = [f"def {name}({', '.join(args)}, out):"] + body
        lines += [f"    out[{k}] = {source(o)}" for k, o in enumerate(outputs)]
        lines.append("    return out")
        return "\n".join(lines) + "\n"
    # an output that is a constant (an effect switched off) still gets the broadcast shape of the inputs
    zeros = f"_np.zeros_like({' + '.join(args)}, dtype=float)" if args else "0.0"
    returned = [f"{source(o)} + {zeros}" if o[0] == "const" else source(o) for o in outputs]
    lines = [f"def {name}({', '.join(args)}):"] + body
    lines.append("    return (" + "".join(f"{o}, " for o in returned) + ")")
    return "\n".join(lines) + "\n"


def _fold(op, values):
    """Evaluate one CasADi operation on constants, with CasADi itself (no re-typed formulas)."""
    x = [ca.SX.sym(f"c{i}") for i in range(len(values))]
    expr = ca.SX.binary(op, x[0], x[1]) if len(values) == 2 else ca.SX.unary(op, x[0])
    return float(ca.Function("fold", x, [expr])(*values))


def _eliminate_common_subexpressions(fun: ca.Function) -> ca.Function:
    """The same function with CasADi's common-subexpression elimination applied to its outputs."""
    ins = fun.sx_in()
    joined = ca.cse(ca.vertcat(*fun.call(ins)))
    return ca.Function(fun.name(), ins, ca.vertsplit(joined), fun.name_in(), fun.name_out())


def numpy_function(fun: ca.Function, into: bool = False):
    """Compile :func:`numpy_source` of ``fun`` into a callable (``into=True``: it takes a last
    argument ``out`` and fills its rows with the outputs).

    Parameters
    ----------
    fun : casadi.Function
        A function with scalar inputs and outputs (see :func:`numpy_source`).
    into : bool, optional
        Generate the variant that writes into a caller's array ``out`` (default False).

    Returns
    -------
    callable
        ``f(i0, i1, …)`` returning a tuple of arrays, one per output of ``fun`` (or ``f(i0, …, out)``
        returning ``out``), equal to CasADi's evaluation to rounding.

    Raises
    ------
    ValueError, NotImplementedError
        As :func:`numpy_source`.

    Examples
    --------
    >>> import casadi as ca
    >>> x = ca.SX.sym("x")
    >>> f = numpy_function(ca.Function("f", [x], [x * x + 1, 2 * x]))
    >>> [v.tolist() for v in f(np.array([0.0, 0.5]))]
    [[1.0, 1.25], [0.0, 1.0]]
    """
    name = "_" + "".join(c if c.isalnum() else "_" for c in fun.name())
    namespace = {"_np": np}
    exec(compile(numpy_source(fun, name, into), f"<coexist generated {fun.name()}>", "exec"), namespace)
    generated = namespace[name]
    generated.__doc__ = f"numpy translation of CasADi function {fun.name()!r}"
    return generated


#: suffix of the float variant of a generated function in a module (:func:`numpy_module_source`)
SCALAR_SUFFIX = "__scalar"


def numpy_module_source(functions) -> str:
    """Python source of a module holding the numpy translations of several CasADi functions.

    Parameters
    ----------
    functions : iterable of (str, casadi.Function, bool)
        ``(name, fun, into)``: the generated ``def name`` translates ``fun`` (see
        :func:`numpy_source`; ``into=True`` writes into a last argument ``out``).

    Returns
    -------
    str
        The module's source; it imports numpy as ``_np`` and defines one function per entry, and beside each its
        float variant ``name`` + :data:`SCALAR_SUFFIX` (``numpy_source(..., scalar=True)``, for :func:`small_batch`).

    Examples
    --------
    >>> import casadi as ca
    >>> x = ca.SX.sym("x")
    >>> src = numpy_module_source([("square", ca.Function("f", [x], [x * x]), False)])
    >>> namespace = {}
    >>> exec(src, namespace)
    >>> namespace["square"](3.0)
    (9.0,)
    """
    parts = [
        '"""Generated by coexist.numerics.codegen from CasADi expressions: do not edit."""\n',
        "import numpy as _np\n",
        _SCALAR_HELPERS,
    ]
    for name, fun, into in functions:
        parts.append("\n" + numpy_source(fun, name, into))
        parts.append("\n" + numpy_source(fun, name + SCALAR_SUFFIX, scalar=True))
    return "\n".join(parts)


#: batches up to this many states take the float code (:func:`small_batch`); numpy's per-operation cost is
#: about that of 20 float operations, so the float code wins below some 20 states
SMALL_BATCH = 8


def small_batch(vector, scalar, into: bool = False):
    """A generated function that evaluates a few states at a time by its float variant, state by state.

    ``vector`` is the numpy function (:func:`numpy_source`), ``scalar`` its float variant (``scalar=True``). A
    call whose array arguments are all one-dimensional of one length ``m ≤`` :data:`SMALL_BATCH` (the others
    scalars) runs ``scalar`` per state and returns arrays of length ``m``, as ``vector`` would; anything else (and
    a state where ``math`` raises: a negative square root, a division by zero, an overflow) goes to ``vector``,
    so the result is numpy's in every case, to rounding and in float64 (``tests/test_model.py``; float32 inputs
    come back as float64 here).

    Parameters
    ----------
    vector, scalar : callable
        The two forms of one generated function.
    into : bool, optional
        ``vector`` writes its outputs into a last argument ``out`` (rows ``0 … k−1``) and returns it.

    Returns
    -------
    callable
        The dispatching function, with ``vector``'s signature.

    Examples
    --------
    >>> import casadi as ca
    >>> x = ca.SX.sym("x")
    >>> f = ca.Function("f", [x], [ca.sqrt(x), 2 * x])
    >>> both = small_batch(numpy_function(f), _scalar_function(f))
    >>> [v.tolist() for v in both(np.array([4.0, 9.0]))]
    [[2.0, 3.0], [8.0, 18.0]]
    >>> with np.errstate(invalid="ignore"):  # math.sqrt(-1) raises: numpy's NaN
    ...     [v.tolist() for v in both(np.array([-1.0, 9.0]))]
    [[nan, 3.0], [-2.0, 18.0]]
    """

    def call(*args):
        ins = args[:-1] if into else args
        m = 0
        for a in ins:
            if type(a) is np.ndarray:
                if a.ndim != 1 or (m and a.size != m):
                    return vector(*args)
                m = a.size
            elif not isinstance(a, (float, int)):
                return vector(*args)
        if not 0 < m <= SMALL_BATCH:
            return vector(*args)
        # (a large batch is not turned into lists before it is sent to the numpy code; this runs some 10⁵ times a
        # command, for one to three states mostly, so each step here costs about as much as the float code itself)
        columns = [a.tolist() if type(a) is np.ndarray else [float(a)] * m for a in ins]
        try:  # (Python floats only: numpy's error state plays no part)
            rows = list(map(scalar, *columns))
        except (ArithmeticError, ValueError):
            return vector(*args)
        values = np.array(rows, dtype=float).T
        if into:
            out = args[-1]
            out[: values.shape[0]] = values
            return out
        return tuple(values)

    call.__doc__ = vector.__doc__
    call.__wrapped__ = vector  # type: ignore[attr-defined]  # the generated numpy code (inspect.unwrap)
    call.scalar = scalar  # type: ignore[attr-defined]
    return call


def _scalar_function(fun: ca.Function):
    """The float variant of ``fun`` as a callable (tests and examples; the model's come from its module)."""
    namespace: dict = {}
    exec(_SCALAR_HELPERS + numpy_source(fun, "f", scalar=True), namespace)
    return namespace["f"]
