"""Newton's solvers of the fast sweep (:mod:`bridgeflap.model.stability.hopf`): the Hopf point, the
real-eigenvalue crossing, inverse iteration, and the static roots that seed the divergence Newton.

Split from :mod:`bridgeflap.model.stability.hopf` (file size); the method is described there.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg as sla

from bridgeflap.model.stability.tracking import _A, NEWTON_RTOL, _dA, _scale

#: Newton iterations at most (the residual test is :data:`model.stability.tracking.NEWTON_RTOL`)
NEWTON_MAXITER = 30


class FastPathError(Exception):
    """The fast path is unsure; the message is the fallback reason."""


# ------------------------------------------------------------------ Newton

def hopf_newton(system, u0, lam0, v0, c=None, maxiter=NEWTON_MAXITER, bounds=(0.0, np.inf)):
    """Newton on the Hopf point ``(A(U) - i w I) v = 0``, ``c^H v = 1``.

    Starts from ``U = u0`` [m/s], ``w = Im lam0`` [rad/s], ``v = v0``. Returns
    ``(U, w, v, relative residual, iterations)``; raises :class:`FastPathError` when Newton does
    not converge or leaves ``bounds``.
    """
    v = np.asarray(v0, complex)
    c = v / np.vdot(v, v).real if c is None else c
    v = v / np.vdot(c, v)
    U, w = float(u0), float(lam0.imag)
    nx = v.size
    cr, ci = c.real, c.imag
    res = np.inf
    for it in range(1, maxiter + 1):
        A = _A(system, U)
        r = A @ v - 1j * w * v
        s = np.vdot(c, v) - 1.0
        res = float(np.linalg.norm(r)) / (_scale(A) * float(np.linalg.norm(v)))
        M = A - 1j * w * np.eye(nx)
        J = np.zeros((2 * nx + 2, 2 * nx + 2))
        J[:nx, :nx], J[:nx, nx:2 * nx] = M.real, -M.imag
        J[nx:2 * nx, :nx], J[nx:2 * nx, nx:2 * nx] = M.imag, M.real
        J[:nx, 2 * nx], J[nx:2 * nx, 2 * nx] = v.imag, -v.real
        dv = _dA(system, U) @ v
        J[:nx, 2 * nx + 1], J[nx:2 * nx, 2 * nx + 1] = dv.real, dv.imag
        J[2 * nx, :nx], J[2 * nx, nx:2 * nx] = cr, ci
        J[2 * nx + 1, :nx], J[2 * nx + 1, nx:2 * nx] = -ci, cr
        rhs = -np.concatenate([r.real, r.imag, [s.real, s.imag]])
        try:
            x = np.linalg.solve(J, rhs)
        except np.linalg.LinAlgError:
            raise FastPathError("Newton (Hopf): singular Jacobian") from None
        v = v + x[:nx] + 1j * x[nx:2 * nx]
        w, U = w + x[2 * nx], U + x[2 * nx + 1]
        if not (bounds[0] <= U <= bounds[1]) or not np.isfinite(U):
            raise FastPathError(f"Newton (Hopf) left the bracket (U = {U:.6g} m/s)")
        if abs(x[2 * nx + 1]) <= 1e-13 * max(abs(U), 1.0) and res <= NEWTON_RTOL:
            A = _A(system, U)
            res = float(np.linalg.norm(A @ v - 1j * w * v)) / (_scale(A) * np.linalg.norm(v))
            return U, w, v, res, it
    raise FastPathError(f"Newton (Hopf) did not converge in {maxiter} iterations "
                        f"(residual {res:.2g})")


def divergence_newton(system, u0, v0, maxiter=NEWTON_MAXITER, bounds=(0.0, np.inf)):
    """Newton on the real-eigenvalue crossing ``A(U) v = 0``, ``c^T v = 1`` (``U``, ``v`` real).

    Returns ``(U, v, relative residual, iterations)``; raises :class:`FastPathError`.
    """
    v = np.asarray(v0, float)
    c = v / float(v @ v)
    U, nx = float(u0), v.size
    res = np.inf
    for it in range(1, maxiter + 1):
        A = _A(system, U)
        r = A @ v
        res = float(np.linalg.norm(r)) / (_scale(A) * float(np.linalg.norm(v)))
        J = np.zeros((nx + 1, nx + 1))
        J[:nx, :nx], J[:nx, nx], J[nx, :nx] = A, _dA(system, U) @ v, c
        try:
            x = np.linalg.solve(J, -np.concatenate([r, [c @ v - 1.0]]))
        except np.linalg.LinAlgError:
            raise FastPathError("Newton (divergence): singular Jacobian") from None
        v, U = v + x[:nx], U + x[nx]
        if not (bounds[0] <= U <= bounds[1]) or not np.isfinite(U):
            raise FastPathError(f"Newton (divergence) left the bracket (U = {U:.6g} m/s)")
        if abs(x[nx]) <= 1e-13 * max(abs(U), 1.0) and res <= NEWTON_RTOL:
            A = _A(system, U)
            res = float(np.linalg.norm(A @ v)) / (_scale(A) * float(np.linalg.norm(v)))
            return U, v, res, it
    raise FastPathError(f"Newton (divergence) did not converge in {maxiter} iterations "
                        f"(residual {res:.2g})")


def _inverse_vector(system, U, shift, real=False):
    """Eigenvector of ``A(U)`` for the eigenvalue nearest ``shift``: two inverse iterations."""
    A = _A(system, U)
    nx = A.shape[0]
    M = A - shift * np.eye(nx) if not real else A - float(np.real(shift)) * np.eye(nx)
    lu = sla.lu_factor(M, check_finite=False)
    x = np.linspace(1.0, 2.0, nx) + (0 if real else 0.1j)
    for _ in range(3):
        x = sla.lu_solve(lu, x, check_finite=False)
        x = x / np.linalg.norm(x)
    return x


def static_roots(system) -> np.ndarray:
    """Every ``U > 0`` [m/s] with ``det(K - U^2 Q) = 0`` (the static condition,
    :func:`bridgeflap.model.aeroelastic.statespace.static_aero_stiffness`), ascending; empty when
    there is none or the
    system has no static stiffness (``C(0) = 1``: exact for the RFA)."""
    from bridgeflap.model.aeroelastic.statespace import static_aero_stiffness

    try:
        K, Q = np.asarray(system.basis.K, float), static_aero_stiffness(system)
        mu = np.linalg.eigvals(np.linalg.solve(K, Q))
    except (AttributeError, TypeError, ValueError, np.linalg.LinAlgError):
        return np.zeros(0)
    real = mu[(np.abs(mu.imag) <= 1e-9 * np.abs(mu).max()) & (mu.real > 0)].real
    return np.sort(1.0 / np.sqrt(real))


def _static_seeded(newton, system, a, b):
    """Divergence Newton started at the smallest static root in the coarse bracket ``(a, b)``.

    A real eigenvalue of ``A(U)`` is zero exactly where ``det(K - U^2 Q) = 0``: with
    ``C(0) = 1`` the lag states (poles ``-beta U / b``) and a stable compensator are invertible
    at ``s = 0`` for ``U > 0``, so ``det A(U)`` is ``det K_ae(U)`` times a non-zero factor. The
    first zero crossing of the divergence indicator in the bracket (stable at ``a``) is therefore
    the smallest root there. Used when the interpolated start fails: the closed-loop divergence
    eigenvalue of the default design rises from -0.03 to +0.11 1/s across a 12.75 m/s coarse
    step, steeply near its end, past a cluster of real eigenvalues near -0.036 1/s, so the
    linear zero (1.5 m/s above ``a``) is 10 m/s short of the root and Newton leaves the bracket.
    The result is verified as any other (:func:`_divergence`); no root in the bracket: the
    original error (a coalescence, not a zero crossing; :func:`_grid_crossing` decides).
    """
    roots = [r for r in static_roots(system) if a <= r <= b]
    if not roots:
        raise FastPathError("divergence: Newton failed and no static root in the bracket")
    u0 = float(roots[0])
    # inverse iteration at the root itself: A(u0) is singular to round-off, so two solves give
    # its null vector (nudged below the root: an exactly zero pivot is never factorised)
    u_start = u0 * (1.0 - 1e-9)
    return newton(_inverse_vector(system, u_start, 0.0, real=True), u_start)
