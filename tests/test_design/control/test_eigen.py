"""Tests of design/control/formulation/eigen.py (eigenvalue callback and its use in Ipopt) and
model/spectrum.py."""

import casadi as ca
import numpy as np
import pytest
import scipy.linalg
import scipy.optimize

from bridgeflap.design.control.formulation.eigen import PolynomialTopRealParts
from bridgeflap.model.spectrum import (
    eigenvalue_derivative,
    eigenvalue_derivatives,
    spectral_abscissa,
)


def _top(A_fun, m, **kwargs):
    """Top-``m`` real parts of the single matrix ``A_fun(p)`` (one part, one speed)."""
    return PolynomialTopRealParts(A_fun, [1.0], m, **kwargs)


def _random_affine_family(seed=3, n=6, n_p=3):
    """A(p) = A0 + sum_k p_k A_k, random nonsymmetric, with well-separated eigenvalues at p0."""
    rng = np.random.default_rng(seed)
    A0 = rng.standard_normal((n, n))
    Ak = [rng.standard_normal((n, n)) for _ in range(n_p)]
    p = ca.SX.sym("p", n_p)
    A = ca.DM(A0)
    for k in range(n_p):
        A = A + p[k] * ca.DM(Ak[k])
    A_fun = ca.Function("A", [p], [A], ["p"], ["A"])
    p0 = 0.1 * rng.standard_normal(n_p)
    return A_fun, p0


def _casadi_jacobian(cb, n_p):
    """Jacobian of a callback through CasADi's AD machinery (exercises get_jacobian)."""
    x = ca.MX.sym("x", n_p)
    return ca.Function("J", [x], [ca.jacobian(cb(x), x)])


def _central_fd(fun, p, h):
    p = np.asarray(p, dtype=float)
    cols = []
    for k in range(p.size):
        e = np.zeros_like(p)
        e[k] = h
        cols.append((fun(p + e) - fun(p - e)) / (2.0 * h))
    return np.column_stack(cols)


def _oscillator_family():
    """2-DOF chain (unit masses, K = [[2,-1],[-1,2]] N/m) with negative damping on mass 1.

    p = velocity-feedback gains [N s/m] added to each mass's damping. At p = 0 the damping
    matrix diag(-0.1, 0.05) gives both modes modal damping -0.025 N s/m: unstable.
    """
    K = np.array([[2.0, -1.0], [-1.0, 2.0]])
    C0 = np.diag([-0.1, 0.05])
    p = ca.SX.sym("p", 2)
    A = ca.vertcat(
        ca.horzcat(ca.DM.zeros(2, 2), ca.DM.eye(2)),
        ca.horzcat(ca.DM(-K), -(ca.DM(C0) + ca.diag(p))),
    )
    return ca.Function("A", [p], [A], ["p"], ["A"])


def test_top_real_parts_jacobian_matches_central_differences():
    A_fun, p0 = _random_affine_family()
    A = np.asarray(A_fun(p0).full())
    lam = np.linalg.eigvals(A)
    gaps = np.abs(lam[:, None] - lam[None, :]) + np.eye(lam.size) * 1e9
    # Distinct, well-separated eigenvalues (simple, far from crossing) so the real parts are
    # smooth and sorting is stable over the FD stencil; conjugate pairs have |lambda-conj| > 0.
    assert gaps.min() > 0.05
    cb = _top(A_fun, 6)
    J = np.asarray(_casadi_jacobian(cb, 3)(p0).full())
    values = lambda p: np.asarray(cb(ca.DM(p)).full()).ravel()  # noqa: E731
    J_fd = _central_fd(values, p0, 1e-6)
    # Central FD: truncation O(h^2 |d3 lambda|) ~ 1e-12 and round-off eps*|lambda|/h ~ 1e-10
    # for h = 1e-6 and |lambda| ~ 3; a 1e-7 relative (to max|J|) tolerance leaves > 100x margin.
    np.testing.assert_allclose(J, J_fd, rtol=0, atol=1e-7 * np.abs(J_fd).max())
    assert cb.fd_fallback_count == 0
    # Values: sorted descending and equal to a dense eig (same LAPACK call, so ~ machine eps).
    v = values(p0)
    assert np.all(np.diff(v) <= 0.0)
    np.testing.assert_allclose(v, np.sort(lam.real)[::-1], rtol=0, atol=1e-12)


def test_sensitivity_formula_on_diagonalisable_analytic_case():
    # A(p) = [[p, 1], [-1, p]] has eigenvalues p +- i, so d Re(lambda)/dp = 1 exactly.
    A = np.array([[0.3, 1.0], [-1.0, 0.3]])
    lam, vl, vr = scipy.linalg.eig(A, left=True, right=True)
    dlam, ill = eigenvalue_derivatives(vl, vr, np.eye(2).reshape(4, 1, order="F"))
    np.testing.assert_allclose(lam.real, [0.3, 0.3], atol=1e-15)
    # Exact value 1; LAPACK eigenvectors give it to a few ulps.
    np.testing.assert_allclose(dlam[:, 0], [1.0, 1.0], atol=1e-14)
    assert not ill.any()
    # the single-pair form is the same formula: w^H dA v / (w^H v)
    for i in range(2):
        ref = np.vdot(vl[:, i], np.eye(2) @ vr[:, i]) / np.vdot(vl[:, i], vr[:, i])
        assert eigenvalue_derivative(vl[:, i], vr[:, i], np.eye(2)) == pytest.approx(ref)
    # d lambda / dp of A = [[0, 1], [-1, 0]] + p [[0, 0], [1, 0]] at p = 0: lambda = +-i
    # sqrt(1 - p), so d lambda/dp = -+ i/2 (complex derivative, analytic)
    lam, vl, vr = scipy.linalg.eig(np.array([[0.0, 1.0], [-1.0, 0.0]]), left=True, right=True)
    d = [eigenvalue_derivative(vl[:, i], vr[:, i], np.array([[0.0, 0.0], [1.0, 0.0]]))
         for i in range(2)]
    np.testing.assert_allclose(d, -0.5j * np.sign(lam.imag), atol=1e-15)


def test_defective_eigenvalue_falls_back_to_finite_differences():
    # Jordan block at p = (p0, 0): A = [[p0, 1], [p1, p0]] has eigenvalues p0 +- sqrt(p1),
    # defective at p1 = 0 (w^H v = 0). The derivative w.r.t. p0 is exactly 1 for both.
    p = ca.SX.sym("p", 2)
    A_fun = ca.Function("A", [p], [ca.vertcat(ca.horzcat(p[0], 1.0), ca.horzcat(p[1], p[0]))])
    cb = _top(A_fun, 2)
    J = np.asarray(_casadi_jacobian(cb, 2)(ca.DM([0.2, 0.0])).full())
    assert cb.fd_fallback_count == 2
    assert np.all(np.isfinite(J))
    # Shifting p0 moves both eigenvalues rigidly, so the FD column is exact up to round-off
    # eps/h ~ 1e-10 (h = 1e-6).
    np.testing.assert_allclose(J[:, 0], [1.0, 1.0], atol=1e-8)


def test_ipopt_minimum_norm_stabilising_feedback():
    A_fun = _oscillator_family()
    assert spectral_abscissa(np.asarray(A_fun([0.0, 0.0]).full())) > 0.0  # unstable at p = 0
    margin = 0.05  # required decay rate [1/s]
    cb = _top(A_fun, 4)  # keep alive: referenced by the solver below
    x = ca.MX.sym("x", 2)
    solver = ca.nlpsol(
        "stabilise",
        "ipopt",
        {"x": x, "f": ca.sumsqr(x), "g": cb(x)},
        {
            "ipopt.hessian_approximation": "limited-memory",
            "ipopt.tol": 1e-10,
            "ipopt.constr_viol_tol": 1e-10,
            "ipopt.print_level": 0,
            "ipopt.sb": "yes",
            "print_time": False,
        },
    )
    sol = solver(x0=[0.0, 0.0], lbg=-np.inf, ubg=-margin)
    assert solver.stats()["return_status"] == "Solve_Succeeded"
    p_opt = np.asarray(sol["x"].full()).ravel()
    g_opt = np.asarray(sol["g"].full()).ravel()
    alpha = spectral_abscissa(np.asarray(A_fun(p_opt).full()))
    # A posteriori dense eig agrees with the constraint value (same matrix, same LAPACK
    # routine: agreement to round-off), and the constraint holds to Ipopt's tolerance 1e-10
    # (1e-9 allows for Ipopt's internal scaling of the constraint).
    assert abs(alpha - g_opt[0]) < 1e-12
    assert alpha <= -margin + 1e-9
    # Cross-method: SLSQP with finite-difference gradients of a plain numpy constraint. The
    # problem is smooth at the optimum (two distinct complex pairs, both active), so both
    # methods find the same point; SLSQP's FD gradients (step ~1.5e-8) limit it to ~1e-6.
    ref = scipy.optimize.minimize(
        lambda q: q @ q,
        x0=[0.2, 0.2],
        constraints=[
            {
                "type": "ineq",
                "fun": lambda q: -margin - np.linalg.eigvals(np.asarray(A_fun(q).full())).real,
            }
        ],
        method="SLSQP",
        options={"ftol": 1e-12, "maxiter": 200},
    )
    assert ref.success
    np.testing.assert_allclose(p_opt, ref.x, atol=1e-5)


def test_callback_rejects_bad_arguments():
    A_fun, _ = _random_affine_family()
    with pytest.raises(ValueError, match="m must be"):
        _top(A_fun, 7)
    with pytest.raises(ValueError, match="square"):
        spectral_abscissa(np.zeros((2, 3)))


def test_non_finite_matrix_gives_nan_not_exception():
    # "Solver failure is data": a NaN in A(p) yields NaN values and Jacobian for Ipopt to reject.
    p = ca.SX.sym("p", 1)
    A_fun = ca.Function("A", [p], [ca.vertcat(ca.horzcat(ca.log(p), 1.0), ca.horzcat(0.0, -1.0))])
    cb = _top(A_fun, 2)
    assert np.all(np.isnan(np.asarray(cb(ca.DM(-1.0)).full())))
    assert np.all(np.isnan(np.asarray(_casadi_jacobian(cb, 1)(-1.0).full())))


def test_polynomial_top_real_parts_matches_fd_and_single_speed_callbacks():
    # A(U, p) = A0(p) + U A1(p) + U^2 A2(p), nonlinear in p, with a state subset at U = 0.
    rng = np.random.default_rng(5)
    n = 6
    M = [ca.DM(rng.standard_normal((n, n))) for _ in range(6)]
    p = ca.SX.sym("p", 3)
    parts = ca.Function("parts", [p], [M[0] + p[0] * M[1] + p[1] * p[2] * M[2],
                                       M[3] * p[2] + M[4], 0.1 * p[0] ** 2 * M[5]])
    speeds = [0.0, 0.5, 1.0]
    keep = [0, 1, 2, 4]
    cb = PolynomialTopRealParts(parts, speeds, 3, subsets={0.0: keep})
    p0 = np.array([0.3, -0.2, 0.5])
    J = np.asarray(_casadi_jacobian(cb, 3)(p0).full())
    J_fd = _central_fd(cb._plain_values, p0, 1e-6)
    # central FD with h = 1e-6: truncation ~1e-12, round-off eps |lambda| / h ~ 1e-9 for
    # |lambda| ~ 3; 1e-7 relative to max |J| leaves a 100x margin
    np.testing.assert_allclose(J, J_fd, rtol=0, atol=1e-7 * np.abs(J_fd).max())
    # values equal a dense eig of the same matrices (same LAPACK call)
    vals = np.asarray(cb(p0).full()).ravel()
    for s, u in enumerate(speeds):
        P = [a.full() for a in parts(p0)]
        A = P[0] + u * P[1] + u * u * P[2]
        if u == 0.0:
            A = A[np.ix_(keep, keep)]
        ref = np.sort(np.linalg.eigvals(A).real)[::-1][:3]
        np.testing.assert_allclose(vals[3 * s:3 * s + 3], ref, rtol=0, atol=1e-12)
    assert cb.fd_fallback_count == 0
