"""The design's buffeting term in modal coordinates
(bridgeflap.design.control.formulation.buffeting_term.ModalBuffeting).

Cross-method checks: the closed form in K(j omega) against the numpy state-space integrand of
bridgeflap.model.response.buffeting on the same frozen grid, the solve form (flap weights variable)
against the closed form, exact AD derivatives against central differences, the frozen grid against
the converged adaptive grid, and the K = 0 normalisation.
"""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from bridgeflap.design.control.formulation.buffeting_term import ModalBuffeting
from bridgeflap.design.control.formulation.nlp import DesignProblem
from bridgeflap.model.aero.gust import gust_field
from bridgeflap.model.aeroelastic.control import Compensator
from bridgeflap.model.response.buffeting import reduced_response

THETA = np.array([0.0, 0.5, -1.0, 0.05, 0.5])


@pytest.fixture(scope="module")
def term(buffeting_problem):
    # the small design of tests/conftest.py: the code path of the 16-mode design
    s, spec, model = buffeting_problem
    prob = DesignProblem(s, model, spec=spec)
    return prob, spec, model, ModalBuffeting(prob, THETA)


def test_closed_form_equals_state_space_integrand_on_the_same_grid(term):
    # q = (I - K N)^{-1} X_g w is the frequency response of the closed-loop RFA state space
    # (A_cl, B_gust): same grid, same trapezoid rule, so only round-off differs (observed
    # 6e-13 relative on 16 modes, 1e-14 here); 1e-9 leaves room for BLAS order
    prob, spec, model, mb = term
    sys_cl = model.system(Compensator(*THETA), weights=prob.weights)
    gust = gust_field(spec)
    z, a = mb.rms(THETA)
    for i, U in enumerate(mb.speeds_m_s):
        r = reduced_response(sys_cl.A(U), sys_cl.B_gust(U), sys_cl.C_out, sys_cl.basis.strip_x,
                             U, gust, omegas=mb.omegas[i])
        jv, jt = mb.rows[i]
        assert z[i] == pytest.approx(r.rms[jv], rel=1e-9)
        assert a[i] == pytest.approx(r.rms[jt], rel=1e-9)


def test_solve_form_equals_closed_form(term):
    # the placement form (w a variable: the low-rank Woodbury form, one r x r solve per
    # frequency) and the closed form (eigendecomposition of N with w fixed) are the same
    # algebra: round-off only
    prob, _, _, mb = term
    ms = ModalBuffeting(prob, THETA, fixed_layout=False)
    for th in (THETA, np.array([0.2, -0.4, -2.0, 0.03, 0.8])):
        assert float(ms(th, prob.weights)) == pytest.approx(float(mb(th, prob.weights)),
                                                            rel=1e-10)


def test_defective_loop_matrix_falls_back_to_the_lowrank_form(term, monkeypatch):
    # a nearly defective loop matrix (a placed layout in a multi-model design: "loop matrix
    # nearly defective (cond(V) 1.6e18)" ended a start) no longer raises: the fixed layout's
    # speeds are built in the low-rank form, exact without eigenvectors -- the closed form's
    # value to round-off (same algebra, 1e-10 as the test above)
    import bridgeflap.design.control.formulation.buffeting_term as bt

    prob, _, _, mb = term

    def defective(*a, **k):
        raise np.linalg.LinAlgError("loop matrix nearly defective (test)")

    monkeypatch.setattr(bt, "_eig_point_data", defective)
    fb = ModalBuffeting(prob, THETA)
    assert fb.defective_fallbacks == len(fb.speeds_m_s) and mb.defective_fallbacks == 0
    for th in (THETA, np.array([0.2, -0.4, -2.0, 0.03, 0.8])):
        assert float(fb(th, prob.weights)) == pytest.approx(float(mb(th, prob.weights)),
                                                            rel=1e-10)


def test_zero_gain_is_the_normalisation(term):
    # J_buf = 0.5 mean(ratio_z^2 + ratio_a^2) with the K = 0 loop as reference: exactly 1
    prob, _, _, mb = term
    assert float(mb(np.array([0.0, 0.0, 0.0, 0.05, 0.5]), prob.weights)) == pytest.approx(
        1.0, rel=1e-12)


def test_gradients_match_central_differences(term):
    # exact AD vs central differences (h = 1e-6): truncation ~h^2 f''' and round-off
    # ~eps J / h are both ~1e-10; 1e-6 of the largest entry is generous, and the gradient
    # must not vanish (the term acts on K)
    prob, _, model, mb = term
    th = ca.MX.sym("th", 5)
    g = np.asarray(ca.Function("g", [th], [ca.gradient(mb(th, prob.weights), th)])(THETA)
                   .full()).ravel()
    f = lambda p: float(mb(p, prob.weights))  # noqa: E731
    gfd = np.array([(f(THETA + e) - f(THETA - e)) / 2e-6 for e in np.eye(5) * 1e-6])
    np.testing.assert_allclose(g, gfd, rtol=0, atol=1e-6 * np.abs(gfd).max())
    assert np.abs(g).max() > 1e-4
    # in the flap weights (solve form): same check
    ms = ModalBuffeting(prob, THETA, fixed_layout=False)
    w = ca.MX.sym("w", model.n_flaps)
    w0 = 0.7 * np.ones(model.n_flaps)
    gw = np.asarray(ca.Function("gw", [w], [ca.gradient(ms(THETA, w), w)])(w0).full()).ravel()
    fw = lambda v: float(ms(THETA, v))  # noqa: E731
    gwfd = np.array([(fw(w0 + e) - fw(w0 - e)) / 2e-6 for e in np.eye(model.n_flaps) * 1e-6])
    np.testing.assert_allclose(gw, gwfd, rtol=0, atol=1e-6 * np.abs(gwfd).max())


def test_frozen_grid_against_the_converged_adaptive_grid(term):
    # the frozen grid (open loop + reference design) against model.response.buffeting's adaptive
    # grid, converged to 5e-3: at the reference and at a design away from it (observed 1e-3 on 16
    # modes at the designed K); 1e-2 = twice the adaptive grid's own tolerance
    prob, _, _, mb = term
    for th in (THETA, np.array([0.2, -0.4, -2.0, 0.03, 0.8])):
        c = mb.check(prob, th)
        assert c["max_relative_difference"] < 1e-2


def test_compiled_point_function_equals_the_virtual_machine():
    # the JIT-compiled closed form (design.control.formulation.buffeting_term.JIT) is the same SX
    # expression evaluated by C code instead of CasADi's virtual machine: only the floating-point
    # evaluation order may differ (-O2 keeps IEEE semantics), so values and reverse-mode
    # gradients agree to round-off; 1e-12 relative is ~1e4 ulps on sums of ~1e3 terms
    import bridgeflap.design.control.formulation.buffeting_term as bt

    n = 6
    rng = np.random.default_rng(3)
    fc, fv = bt._eig_point_function(n, jit=True), bt._eig_point_function(n, jit=False)
    if fc is fv or "compile failed" in bt.JIT_STATUS:
        pytest.skip(f"no compiler: {bt.JIT_STATUS}")
    m = 40
    th = ca.MX.sym("theta", 5)
    data = [ca.DM(rng.uniform(0.1, 3.0, (1, m))), ca.DM(rng.normal(size=(n, m))),
            ca.DM(rng.normal(size=(n, m)))]
    H = []
    for _ in range(2):
        Z = rng.normal(size=(n, n)) + 1j * rng.normal(size=(n, n))
        Hh = Z @ Z.conj().T
        H += [ca.DM(np.hstack([Hh.real] * m)), ca.DM(np.hstack([Hh.imag] * m))]
    x = np.array([-0.8, 0.3, -2.7, 0.28, 0.03])
    outs = []
    for f in (fc, fv):
        J = ca.sum2(f.map(m, "serial")(th, *data, *H))
        g = ca.Function("g", [th], [J, ca.jacobian(J, th)])
        outs.append([np.asarray(v.full()) for v in g(x)])
    for a, b in zip(outs[0], outs[1], strict=True):
        np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-12 * np.abs(b).max())


def test_compiled_point_function_writes_nothing_in_the_working_directory(tmp_path, monkeypatch):
    # CasADi's JIT writes its C source and library into the current directory by default;
    # bridgeflap's go to a private temporary directory (a user's folder stays clean)
    import bridgeflap.design.control.formulation.buffeting_term as bt

    monkeypatch.chdir(tmp_path)
    bt._POINT_CACHE.pop((3, True), None)
    f = bt._eig_point_function(3, jit=True)
    ca.Function("r", f.sx_in(), [ca.gradient(ca.sum1(f(*f.sx_in())), f.sx_in()[0])])
    assert list(tmp_path.iterdir()) == []


def test_jit_directories_of_finished_processes_are_removed(tmp_path, monkeypatch):
    # CasADi leaves its generated files at exit: the per-process JIT directories under
    # $TMPDIR/bridgeflap_jit_<uid>/ of processes that no longer run are pruned by the next
    # process, so the temporary directory does not grow run after run
    import os
    import subprocess
    import sys

    import bridgeflap.design.control.formulation.buffeting_term as bt

    monkeypatch.setenv("TMPDIR", str(tmp_path))
    code = ("import tempfile, bridgeflap.design.control.formulation.buffeting_term as bt; "
            "tempfile.tempdir = None; "
            "bt._jit_options(); print(bt._JIT_DIR)")
    first = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                           check=True).stdout.strip()
    assert first.startswith(str(tmp_path))
    with open(os.path.join(first, "left_by_casadi.so"), "w") as fh:
        fh.write("x")
    second = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                            check=True).stdout.strip()
    assert second != first and not os.path.exists(first)
    assert bt._alive(os.getpid())


def test_point_function_library_is_kept_between_processes(tmp_path):
    # design.control.formulation.buffeting_term._compiled: the first process compiles the point
    # function into the cache directory, the next one loads that library (no compile), and a corrupt
    # library (here: garbage under its name) is rebuilt rather than trusted; every process's values
    # equal the virtual machine's (1e-12 relative, as the compiled-vs-VM test). Each step runs
    # in its own process: a library already loaded in a process is not opened again by name.
    import os
    import subprocess
    import sys

    code = ("import numpy as np, bridgeflap.design.control.formulation.buffeting_term as bt; "
            "f = bt._eig_point_function(4); g = bt._eig_point_function(4, jit=False); "
            "rng = np.random.default_rng(0); "
            "a = [rng.random(f.size_in(i)) for i in range(f.n_in())]; "
            "x, y = np.asarray(f(*a)), np.asarray(g(*a)); "
            "assert np.allclose(x, y, rtol=1e-12, atol=0), (x, y); print(bt.JIT_STATUS)")
    env = {**os.environ, "BRIDGEFLAP_CACHE_DIR": str(tmp_path)}

    def run():
        return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                              env=env, check=True).stdout.strip()

    first = run()
    if "compile failed" in first:
        pytest.skip(f"no compiler: {first}")
    assert first == "compiled"
    libs = sorted((tmp_path / "jit").iterdir())
    assert len(libs) == 1 and libs[0].suffix == ".so"      # no temporary files left behind
    stamp = libs[0].stat().st_mtime_ns
    assert run() == "compiled (cached library)"
    assert libs[0].stat().st_mtime_ns == stamp
    libs[0].unlink()
    libs[0].write_bytes(b"not a shared library")
    assert run() == "compiled"
    assert sorted((tmp_path / "jit").iterdir()) == libs
