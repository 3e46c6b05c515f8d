"""The relaxed interface root (``coexist.patterned_relaxed._increasing_root``) towards a wrinkled far side's pull-in.

Past the maximum of a neo-Hookean side's wrinkled tension ``T̂1ʷ`` the tension falls to ``−∞`` at its pull-in
``λp = 1/Φ̂`` (no natural width beyond: NaN). Where the target lies above the maximum there is no root, but the search
had bisected down to the pull-in at roundoff, ~55 evaluations of ``T̂1ʷ`` (each a natural-width solve), for the NaN:
13 s of the 15 s of ``coexist shape`` on a neo-Hookean tension-field ring (helper-94's s7_20 at 6 kV). Towards a NaN
end it now steps on the secant root of ``g/g'`` (``≈ 2(λp − λ1)`` there), at most 32 evaluations; it still goes on to
the pull-in at roundoff, and every root it finds is the one the bisection found: on the rising branch, and past the
first maximum on a Gent side's stiffened branch (which the tests of ccd9e81's give-up showed to be valid states).
"""

import numpy as np
import pytest

from coexist.effects import Gent, IdealDielectric, NeoHookean
from coexist.model import MembraneModel
from coexist.patterned_relaxed import _increasing_root, relaxed_meridional_tension


def wrinkled_side(model, phi, counter):
    """``(T̂1ʷ, K)`` of a hoop-wrinkled far side at per-layer voltage ``phi``, as ``relaxed_interface_stretch`` builds
    it (locked points ``+∞``), counting its evaluations."""

    def fun(x):
        counter.append(np.size(x))
        x = np.asarray(x, dtype=float)
        ph = np.full(x.shape, phi)
        T1, K, w = relaxed_meridional_tension(model, x, x, ph, np.ones(x.shape, dtype=bool))
        with np.errstate(all="ignore"):
            locked = np.isfinite(w) & ~(np.asarray(model.tensions(x, w, ph)[4]) * np.ones(x.shape) > 0)
        return np.where(locked, np.inf, T1), np.where(locked, np.inf, K)

    return fun


def bisection(fun, target, lo, hi, n=200):
    """A plain bisection of ``fun − target`` on ``[lo, hi]`` (a value at or above the target, or NaN, is above)."""
    for _ in range(n):
        mid = 0.5 * (lo + hi)
        if mid in (lo, hi):
            break
        if fun(np.array([mid]))[0][0] - target < 0:
            lo = mid
        else:
            hi = mid
    return lo, hi


NEO = MembraneModel(NeoHookean(), IdealDielectric())
PHI = 1 / 2.0202048641474213  # the pull-in of T̂1ʷ at λ1 = 2.0202...


@pytest.mark.parametrize(
    "target, x0", [(1.1814873211244956, 1.8717376066348295), (1.2549394374729625, 1.9850694320675344)]
)
def test_no_root_before_a_pull_in_in_few_evaluations(target, x0):
    """Two columns of the s7_20 shape (6 kV): the target lies above T̂1ʷ's maximum (~1.1246 at λ1 ≈ 1.83), the bracket's
    upper end at the pull-in (NaN). 55 evaluations each before (a bisection down to λp at roundoff), 23-24 now."""
    calls = []
    x, ok = _increasing_root(wrinkled_side(NEO, PHI, calls), np.array([target]), np.array([x0]))
    assert np.isnan(x).all() and not ok.any()
    assert len(calls) <= 32, len(calls)


def test_rising_root_next_to_a_no_root_column_is_the_bisections():
    calls = []
    fun = wrinkled_side(NEO, PHI, calls)
    target = np.array([0.9, 1.1814873211244956, 1.05])
    x, ok = _increasing_root(fun, target, np.array([1.5, 1.8717376066348295, 1.3]))
    assert list(ok) == [True, False, True]
    assert len(calls) <= 32, len(calls)
    for j in (0, 2):
        lo, hi = bisection(fun, target[j], 1.0, 1.82)  # the rising branch, below the maximum (~1.1246 at 1.83)
        assert abs(x[j] - 0.5 * (lo + hi)) <= 4e-15 * x[j], (x[j], lo, hi)


def test_root_past_the_first_maximum_on_a_gent_side_is_still_found():
    """Gent (Jlim 97) at Φ̂ = 0.3: T̂1ʷ rises to ~3.36 (λ1 ≈ 3.5), falls to ~−3.1 (λ1 ≈ 5.5), then stiffens up to its
    locking (NaN past λ1 ≈ 9). From a start past the maximum with the target 5 above it, the root is on the
    stiffened branch (a valid state, as the tests of the reverted give-up showed), as the bisection finds it."""
    gent = MembraneModel(Gent(97.0), IdealDielectric())
    calls = []
    fun = wrinkled_side(gent, 0.3, calls)
    x, ok = _increasing_root(fun, np.array([5.0]), np.array([4.0]))
    assert ok.all() and 6.0 < x[0] < 6.5, x  # past the minimum (~−3.1 at λ1 ≈ 5.5)
    lo, hi = bisection(fun, 5.0, 5.75, 8.5)
    assert abs(x[0] - 0.5 * (lo + hi)) <= 4e-15 * x[0], (x[0], lo, hi)
    g, d = fun(x)
    assert abs(g[0] - 5.0) <= 1e-13 * 5.0 and d[0] > 0


def test_the_wrinkled_far_side_starts_each_natural_width_from_the_last():
    """Each evaluation of the wrinkled far side's ``T̂1ʷ(λ1⁺)`` in ``relaxed_interface_stretch`` solves a natural width;
    those of one root search lie close together, and each now starts from the last instead of ``λ1^(−1/2)``. An
    interface of helper-92's s7_5 ring (Gent 60, three passive layers inside, one electrode layer outside at
    per-layer Φ̂ = 0.342): 161 evaluations of the tensions before, 106 now; the root is the same, and it balances
    the meridional force ``n⁺ T̂1ʷ(λ1⁺) = n⁻ T̂1⁻`` with the hoop tension zero at its width, to rounding."""
    from coexist.patterned_relaxed import relaxed_interface_stretch

    model = MembraneModel(Gent(60.0), IdealDielectric(), wrinkling="tension-field")
    calls = []
    tensions = type(model).tensions

    class Counted(MembraneModel):
        def tensions(self, *args):
            calls.append(1)
            return tensions(self, *args)

    counted = Counted(Gent(60.0), IdealDielectric(), wrinkling="tension-field")
    args = [np.array([v]) for v in (1.4352284581719128, 1.435260775046448, 0.0, 1.435212367557369, 0.0, 3.0)]
    phi_out = 0.3424446685387127
    l1, wrinkled, w, force, ok = relaxed_interface_stretch(counted, *args, np.array([phi_out]), np.array([1.0]))
    assert len(calls) <= 120, len(calls)
    assert ok[0] and wrinkled[0]
    assert l1[0] == pytest.approx(4.93687337, rel=1e-8)
    t = model.tensions(np.float64(l1[0]), np.float64(w[0]), np.float64(phi_out))
    assert abs(float(t[1])) <= 1e-12 and float(t[6]) > 0
    assert float(t[0]) == pytest.approx(force[0], rel=1e-13)
