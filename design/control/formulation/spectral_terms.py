"""The closed-form pieces shared by the spectral terms of the design (the buffeting term,
:mod:`bridgeflap.design.control.formulation.buffeting_term`, and the actuator demand,
:mod:`bridgeflap.design.control.formulation.actuator_demand`): the frozen quadrature data of the
modal gust response at one speed, and the symbolic output PSDs of the loop closed by ``K(j
omega)``."""

from __future__ import annotations

import casadi as ca
import numpy as np

from bridgeflap.design.control.formulation.loop_algebra import k_complex


def gust_frequency_data(model, gust, Vt, strip_x, U, systems, n_base=80, peaks_per_mode=25,
                        half_widths=30.0, positive=False):
    """``(omega, X, M)`` of the modal spectral integral at ``U`` [m/s]: the frozen quadrature
    grid (the union of the adaptive grids of ``systems``, state matrices at ``U``; only
    ``omega > 0`` when ``positive``), the flap transfer ``X`` and the gust response cross
    spectrum ``M = E S E^H`` times the trapezoid weights (the buffeting term's
    :class:`~bridgeflap.design.control.formulation.buffeting_term.ModalBuffeting`, and the actuator
    demand)."""
    from bridgeflap.model.aero.gust import coherence_projection
    from bridgeflap.model.response.buffeting import OMEGA_MAX_FACTOR
    from bridgeflap.model.spectral import adaptive_frequency_grid, trapezoid_weights

    om_max = OMEGA_MAX_FACTOR * max(float(np.abs(np.linalg.eigvals(A).imag).max())
                                    for A in systems)
    om = np.unique(np.concatenate([adaptive_frequency_grid(A, om_max, n_base, peaks_per_mode,
                                                           half_widths) for A in systems]))
    if positive:
        om = om[om > 0]
    _, X, Xg = model.gust_plant(float(U), 1j * om)
    S = (gust.psd(om, U) * gust.admittance_sq(om, U))[:, None, None] * \
        coherence_projection(strip_x, Vt.T, om, U, gust.coherence_decay)
    E = Xg @ Vt.T
    M = E @ S.astype(complex) @ np.conj(np.swapaxes(E, 1, 2))
    M = 0.5 * (M + np.conj(np.swapaxes(M, 1, 2)))
    M *= trapezoid_weights(om)[:, None, None]
    return om, X, M


def _quad(zr, zi, Hr, Hi):
    """``z^H H z`` for Hermitian ``H = Hr + i Hi`` and ``z = zr + i zi`` (real arithmetic)."""
    return (ca.dot(zr, ca.mtimes(Hr, zr)) + ca.dot(zi, ca.mtimes(Hr, zi))
            + 2.0 * ca.dot(zi, ca.mtimes(Hi, zr)))


def point_symbols(n):
    """The symbols of a closed-form point function for ``n`` modes and its two output PSDs:
    ``(inputs, (Kr, Ki), (G_1, G_2))`` with ``inputs = [theta, omega, mu_r, mu_i, H0..H3]``
    and ``G = d^T H conj(d)``, ``d = 1 / (1 - K mu)`` (also the actuator-demand term's,
    :mod:`bridgeflap.design.control.formulation.actuator_demand`)."""
    th = ca.SX.sym("theta", 5)
    om = ca.SX.sym("omega")
    mr, mi = ca.SX.sym("mu_r", n), ca.SX.sym("mu_i", n)
    H = [ca.SX.sym(f"H{k}", n, n) for k in range(4)]
    Kr, Ki = k_complex(th, om)
    dr = 1.0 - (Kr * mr - Ki * mi)
    di = -(Kr * mi + Ki * mr)
    q2 = dr * dr + di * di
    zr, zi = dr / q2, di / q2                               # conj(1 / (1 - K mu))
    return ([th, om, mr, mi, *H], (Kr, Ki),
            (_quad(zr, zi, H[0], H[1]), _quad(zr, zi, H[2], H[3])))
