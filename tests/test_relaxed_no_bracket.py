"""The increasing-branch root of the relaxed interface (``coexist.patterned_relaxed._increasing_root``) gives up at
once where no column brackets a root.

Past a pull-in the wrinkled far side of an interface has no root on its rising branch; the search had gone on to
bisect every column towards its unbracketed end (about 50 evaluations of a natural-width solve each, for a NaN
known after the bracket): 83 s of the 88 s of ``coexist shape`` on a one-zone tension-field ring past its pull-in
(helper-88; now about 8 s, the output byte for byte the same).
"""

import numpy as np

from coexist.patterned_relaxed import _increasing_root


class Counted:
    """``fun(x) = (f, f')`` counting its calls."""

    def __init__(self, f, df):
        self.f, self.df, self.calls = f, df, 0

    def __call__(self, x):
        self.calls += 1
        x = np.asarray(x, dtype=float)
        return self.f(x), self.df(x)


def test_no_bracket_anywhere_is_nan_after_the_bracket():
    # rises to its maximum 0 at x = 1 and falls: the target 1 is out of reach (from x0 = 1: g(0.5) < 0, g(2) < 0
    # with a falling slope, so the bracket cannot widen)
    fun = Counted(lambda x: -((x - 1.0) ** 2), lambda x: -2.0 * (x - 1.0))
    x, ok = _increasing_root(fun, 1.0, np.array([1.0, 1.2]))
    assert np.isnan(x).all() and not ok.any()
    assert fun.calls <= 4  # the bracket's two ends (it had been ~54)


def test_a_bracketed_root_is_still_found():
    fun = Counted(lambda x: x**3, lambda x: 3.0 * x**2)
    x, ok = _increasing_root(fun, 8.0, np.array([1.5, 2.5]))
    assert ok.all()
    np.testing.assert_allclose(x, 2.0, rtol=1e-14)


def test_taut_interface_without_a_stable_root_gives_up_at_once(monkeypatch):
    """The taut interface jump (``coexist.patterned.interface_stretch``) likewise: an outer side past its
    electromechanical instability has no root on its stable branch, known from the bracket."""
    from coexist import patterned
    from coexist.model import MembraneModel

    model = MembraneModel()
    calls = []
    real = patterned._meridional_tension
    monkeypatch.setattr(patterned, "_meridional_tension", lambda *a: calls.append(1) or real(*a))
    # an inner passive side at a large stretch against an outer side at a voltage past its instability: the outer
    # tension (λ1 − λ1⁻³λ2⁻² − φ²λ1λ2², with φλ2 = 1.2 > 1) is negative at every λ1, the inner one 2.98
    l1, ok = patterned.interface_stretch(model, np.array([3.0]), np.array([1.5]), 0.0, 1.0, 0.8, 1.0)
    assert np.isnan(l1).all() and not ok.any()
    assert len(calls) <= 6, len(calls)
