"""The branches a ramp figure draws: a stable segment continued past its ends (``Tracer.extend``) is the branch a
whole-branch trace from the segment's middle gives, without tracing the stable part and locating its ends again."""

import numpy as np
import pytest
from conftest import variant

from coexist.simulation import Simulation


def _exact_events(branch):
    """The folds, splits and merges located exactly (where the stability changes, and merges): kind, voltage,
    stability. (Volume folds are left out: which piece of its zone curve a group is on, and so the stability on
    an unstable stretch past a volume fold, is tracked along the trace and may differ with where it started.)"""
    return sorted(
        (e.kind.partition(":")[0], round(e.phi_hat, 7), e.stable_before, e.stable_after, e.phi_hat)
        for e in branch.events
        if e.kind.partition(":")[0] in ("fold", "split", "merge")
        and (e.stable_before != e.stable_after or e.kind.startswith("merge"))
    )


@pytest.mark.parametrize(
    "changes", [dict(), dict(count=2), dict(volume_ml=100)], ids=["tricircle", "2 zones", "100 ml"]
)
def test_extended_segment_is_the_whole_branch(changes):
    sim = Simulation.from_scene(variant(**changes))
    segments = sim.ramp().result.segments
    extended = sim.branches(segments)
    assert len(extended) == len(segments) >= 2
    for seg, ext in zip(segments, extended):
        whole = seg.tracer.trace(seg.points[len(seg.points) // 2], stable_only=False)
        # the segment's own points are kept, in order of arclength, and the branch goes on past them
        s = np.array([p.s for p in ext.points])
        assert np.all(np.diff(s) > 0)
        assert all(any(p is q for q in ext.points) for p in seg.points)
        # the same events where the stability changes, located exactly: the same voltages
        a, b = _exact_events(whole), _exact_events(ext)
        assert [k[:4] for k in a] == [k[:4] for k in b]
        assert np.allclose([k[4] for k in a], [k[4] for k in b], rtol=0, atol=1e-8)
        # its stability along the arclength is consistent: each exact event starts with the stability the one
        # before it left
        changes = [e for e in ext.events if e.stable_before != e.stable_after]
        assert all(a.stable_after == b.stable_before for a, b in zip(changes, changes[1:]))
        # the same ends (a range end or the window), at the same voltages
        for e_whole, e_ext in zip(sorted(whole.ends, key=_key), sorted(ext.ends, key=_key)):
            assert getattr(e_whole, "kind", None) == getattr(e_ext, "kind", None)
            assert getattr(e_whole, "phi_hat", 0.0) == pytest.approx(getattr(e_ext, "phi_hat", 0.0), abs=1e-8)
        # over the same voltages in the window (the branch's points, to a step of the continuation; the last
        # point of a direction may lie past the window's edge by a step)
        lo, hi = seg.tracer.phi_lo, seg.tracer.phi_hi
        phi_w = np.clip([p.phi for p in whole.points], lo, hi)
        phi_e = np.clip([p.phi for p in ext.points], lo, hi)
        assert min(phi_e) == pytest.approx(min(phi_w), abs=0.01) and max(phi_e) == pytest.approx(max(phi_w), abs=0.01)


def _key(e):
    return (getattr(e, "kind", ""), getattr(e, "phi_hat", 0.0))


def test_branch_lines_are_cut_at_the_path_voltages():
    """A branch drawn on the ramp figure stops at the path's first and last voltage (its last point may lie a
    continuation step past them): pieces crossing an edge end on it, pieces outside are left out."""
    from coexist.plotting import _clipped

    x, y = _clipped([-0.1, 0.5, 1.0, 5.2, 5.4, 4.0], [0.0, 1.0, 2.0, 3.0, 4.0, 5.0], (0.0, 5.0))
    keep = ~np.isnan(x)
    assert np.all((x[keep] >= 0.0) & (x[keep] <= 5.0))
    assert x[0] == 0.0 and y[0] == pytest.approx(1.0 / 6.0)  # on the line from (-0.1, 0) to (0.5, 1)
    assert 5.0 in x[keep] and np.isnan(x).sum() == 1  # leaves at 5 kV once, comes back in once
    assert x[-1] == 4.0 and y[-1] == 5.0
    # one piece across the whole window (a path that starts above 0 V: the branch is traced from 0 V), found in
    # review: a line from edge to edge, not two lone points
    x, y = _clipped([0.0, 2.0], [0.0, 2.0], (0.5, 1.0))
    assert x[:2].tolist() == [0.5, 1.0] and y[:2].tolist() == [0.5, 1.0] and np.isnan(x[2:]).all()
    # leaving from a point on an edge breaks the line: no false segment along the edge when it comes back
    x, y = _clipped([0.5, 1.0, 1.5, 0.8], [0.0, 1.0, 5.0, 2.0], (0.0, 1.0))
    assert np.isnan(x[2]) and x[:2].tolist() == [0.5, 1.0] and x[3] == 1.0 and x[-1] == 0.8
