"""The compiled attempt functions: the same numbers as CasADi's virtual machine, a disk cache that is
keyed by the generated source, and a switch that turns compilation off."""

import numpy as np
import pytest

from coexist.model import build_model
from coexist.numerics import compiled as C
from coexist.shooting import attempt_function, solve_states


def test_compiled_function_equals_the_virtual_machine(tmp_path, monkeypatch):
    monkeypatch.setenv("COEXIST_CACHE_DIR", str(tmp_path))
    monkeypatch.setattr(C, "BACKGROUND", False)  # wait for the compiler
    model = build_model("gent", 97.0)
    fun = attempt_function(model, "radius", 9, K=2)
    fast = C.compiled(fun, "coexist_test_attempts")
    if fast is None:
        pytest.skip(f"no compiled code on this machine: {C.STATUS['last']}")
    assert C.STATUS["last"] == "compiled" and len(list(tmp_path.glob("coexist_test_attempts-*.so"))) == 1
    x = np.random.default_rng(1).uniform(0.5, 1.5, (fun.size1_in(0), 3))
    x[4] = 0  # status: active
    np.testing.assert_allclose(fast(x).full(), fun(x).full(), rtol=1e-13, atol=1e-300)
    # a second process (here: a second call) finds it in the cache, without compiling
    again = C.compiled(fun, "coexist_test_attempts", cached_only=True)
    assert again is not None and C.STATUS["last"] == "cached"


def test_compilation_can_be_turned_off(monkeypatch, tmp_path):
    monkeypatch.setenv("COEXIST_CACHE_DIR", str(tmp_path))
    monkeypatch.setenv("COEXIST_COMPILE", "0")
    fun = attempt_function(build_model("neo-hookean"), "radius", 9, K=2)
    assert C.compiled(fun, "coexist_off") is None and "turned off" in C.STATUS["last"]
    assert not list(tmp_path.glob("*.so"))  # no library (generated numpy code may be cached: numerics.cache)


def test_states_do_not_depend_on_the_path_taken(monkeypatch, tmp_path):
    """Small batches in the virtual machine, the compiled attempt function, and large batches in numpy:
    the same statuses, and the same states to the tolerance (the small batches start from another first
    step, so their steps differ: 10 rtol for the states, 100 rtol for their derivatives)."""
    monkeypatch.setenv("COEXIST_CACHE_DIR", str(tmp_path))
    monkeypatch.setattr(C, "BACKGROUND", False)  # compiled in this process at the COMPILE_AFTER-th use
    model = build_model("gent", 97.0)
    l0 = np.linspace(1.05, 6.8, 12)
    phi = np.linspace(0.0, 0.32, 12)
    big = solve_states(model, np.tile(l0, 30), np.tile(phi, 30), derivatives=True)  # 360 > every small limit
    vm = solve_states(model, l0, phi, derivatives=True)
    for _ in range(20):  # past COMPILE_AFTER uses: compiled from here on where a compiler exists
        solve_states(model, l0[:2], phi[:2], derivatives=True)
    if C.STATUS["last"] not in ("compiled", "cached"):
        pytest.skip(f"no compiled code on this machine: {C.STATUS['last']}")
    fast = solve_states(model, l0, phi, derivatives=True)
    # once compiled, a large batch runs through the attempt function too, 256 columns at a time
    chunked = solve_states(model, np.tile(l0, 30), np.tile(phi, 30), derivatives=True)
    np.testing.assert_array_equal(chunked.status, big.status)
    ok = chunked.ok
    np.testing.assert_allclose(chunked.p_hat[ok], big.p_hat[ok], rtol=1e-9)
    np.testing.assert_allclose(chunked.derivatives.dv_dl0[ok], big.derivatives.dv_dl0[ok], rtol=1e-8)
    np.testing.assert_array_equal(chunked.p_hat[:12], chunked.p_hat[-12:])  # chunks: the same numbers
    for st in (vm, fast):
        np.testing.assert_array_equal(st.status, big.status[:12])
        ok = st.ok
        np.testing.assert_allclose(st.p_hat[ok], big.p_hat[:12][ok], rtol=1e-9)
        np.testing.assert_allclose(st.derivatives.dv_dl0[ok], big.derivatives.dv_dl0[:12][ok], rtol=1e-8)


def test_a_large_wrinkled_batch_is_its_states_alone():
    """300 states (293 valid, all hoop-wrinkled: tension-field, Φ̂ = 0.3) in one batch (the relaxed segments run
    through the attempt functions 256 columns a call where compiled, else numpy) and six of them alone: the same
    statuses, states and derivatives (measured: equal to 7e-16)."""
    from coexist.model import build_model as build

    tf = build("gent", 97.0, wrinkling="tension-field")
    lw = np.r_[np.linspace(1.015, 1.045, 150), np.linspace(5.95, 6.9, 150)]
    big = solve_states(tf, lw, 0.3, derivatives=True)
    pick = [0, 77, 149, 150, 222, 299]
    small = solve_states(tf, lw[pick], 0.3, derivatives=True)
    np.testing.assert_array_equal(big.status[pick], small.status)
    ok = small.ok
    assert big.ok.sum() == 293 and np.all(big.wrinkled_fraction[big.ok] > 0) and ok.sum() == 5
    for name in ("p_hat", "v_hat", "q_hat", "min_tension", "max_field"):
        np.testing.assert_allclose(getattr(big, name)[pick][ok], getattr(small, name)[ok], rtol=1e-9, err_msg=name)
    np.testing.assert_allclose(big.derivatives.dp_dl0[pick][ok], small.derivatives.dp_dl0[ok], rtol=1e-8)


def test_a_missing_library_is_compiled_in_the_background(tmp_path, monkeypatch):
    """By default a library missing from the cache is compiled by a detached process: the call returns at once
    (None: the caller keeps the virtual machine), a second compilation meanwhile is not started (one at a time
    per cache), and once the library is in the cache it loads and gives the virtual machine's numbers; a model
    shot again and again in the meantime switches to it (checked by the attempt function's entry)."""
    import time

    monkeypatch.setenv("COEXIST_CACHE_DIR", str(tmp_path))
    if C._compiler() is None or not C.enabled():
        pytest.skip("no C compiler on this machine")
    model = build_model("gent", 97.0)
    fun = attempt_function(model, "radius", 9, K=2)
    assert C.compiled(fun, "coexist_bg_a", key="k1") is None
    assert C.STATUS["last"] == "compiling in the background"
    assert not C.library_path("coexist_bg_a", "k1").exists()  # returned before the compiler finished
    assert C.compiled(attempt_function(model, "radius", 9, K=3), "coexist_bg_b", key="k2") is None
    assert C.STATUS["last"] == "another compilation is running"
    for _ in range(600):  # the detached compiler: some seconds
        if C.load_cached("coexist_bg_a", "k1", fun.name()) is not None:
            break
        time.sleep(0.5)
    fast = C.load_cached("coexist_bg_a", "k1", fun.name())
    assert fast is not None and not (tmp_path / C.COMPILE_LOCK).exists()
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".coexist_bg_a")]  # no temporary file left
    x = np.random.default_rng(2).uniform(0.5, 1.5, (fun.size1_in(0), 3))
    x[4] = 0
    np.testing.assert_allclose(fast(x).full(), fun(x).full(), rtol=1e-13, atol=1e-300)


def test_a_stale_lock_is_taken_over(tmp_path, monkeypatch):
    """A lock left by a compiler that died (older than STALE_LOCK_SECONDS) does not block compiling for ever; a
    fresh one does."""
    import os

    lock = tmp_path / C.COMPILE_LOCK
    lock.write_text("1")
    assert C._take_lock(tmp_path) is None
    old = lock.stat().st_mtime - C.STALE_LOCK_SECONDS - 10
    os.utime(lock, (old, old))
    assert C._take_lock(tmp_path) == lock and lock.read_text() == str(os.getpid())


def test_large_batches_alone_compile_the_attempt_function(tmp_path, monkeypatch):
    """A process that shoots only large batches (200-state curves) had never counted a use of the attempt function,
    so never compiled or loaded it, and shot every batch in numpy (5.7 ms against 3.0 ms compiled for 200 states; a
    single patterned zone's first ``coexist coexistence`` 100 s against 8 s, its derivative passes' batches having
    grown past the chunk size). Each large batch counts as a use now: compiled at the COMPILE_AFTER-th (here in the
    foreground, ``COEXIST_COMPILE=wait``), the rest go to the compiled function, with the numbers the batch had."""
    from coexist.shooting import COMPILE_AFTER, _integrators

    monkeypatch.setenv("COEXIST_CACHE_DIR", str(tmp_path))
    monkeypatch.setenv("COEXIST_COMPILE", "wait")
    if C._compiler() is None or not C.enabled():
        pytest.skip("no C compiler on this machine")
    model = build_model("gent", 97.0)
    l0 = np.linspace(1.01, 4.0, 200)
    first = solve_states(model, l0, 0.1)
    for _ in range(COMPILE_AFTER + 1):
        last = solve_states(model, l0, 0.1)
    entry = _integrators(model)._casadi[("attempts", "radius")]
    assert entry.get("fast"), entry
    np.testing.assert_allclose(last.p_hat, first.p_hat, rtol=1e-9)
    np.testing.assert_allclose(last.v_hat, first.v_hat, rtol=1e-9)


def test_a_sweep_point_waits_for_a_missing_library(tmp_path, monkeypatch):
    """A sweep's points must give the same bits in any process (``coexist.sweep.same_code_path``). With an empty
    cache the first point had left its library to a background compilation and run in the virtual machine, while the
    workers started later loaded the library: on a fresh cache the serial, process-pool and Dask records differed in
    the last bits (the three bit-for-bit tests of tests/test_sweep.py failed there). Inside ``compiled.waiting()`` —
    and so inside a sweep point — a missing library is compiled before ``compiled`` returns; outside it, in the
    background as before."""
    import casadi as ca

    from coexist.scene import load_scene
    from coexist.sweep import same_code_path

    monkeypatch.setenv("COEXIST_CACHE_DIR", str(tmp_path))
    if C._compiler() is None or not C.enabled():
        pytest.skip("no C compiler on this machine")
    x = ca.SX.sym("x", 2)
    fun = ca.Function("coexist_wait_f", [x], [ca.vertcat(x[0] * x[1], x[0] + 2.0)])
    with C.waiting():
        fast = C.compiled(fun, "coexist_wait_a", key="w1")
    assert fast is not None and C.STATUS["last"] == "compiled"
    assert C.library_path("coexist_wait_a", "w1").exists()
    assert fast([3.0, 4.0]).full().ravel().tolist() == [12.0, 5.0]
    assert C._WAITING[0] == 0
    with same_code_path(load_scene("tricircle")):
        assert C._WAITING[0] == 1
    assert C._WAITING[0] == 0
