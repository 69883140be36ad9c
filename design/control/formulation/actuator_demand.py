"""Actuator demand as a design constraint: the 3 sigma flap angle and rate of the linear closed
loop in the bridge's design turbulence, as CasADi expressions of the compensator coefficients.

The flap angle at a flap is ``beta = K(j omega) alpha_f`` with ``alpha_f = Phi_a[f] q`` the deck
pitch at that flap. The closed-loop PSD of ``alpha_f`` is the modal spectral integrand of the
buffeting term (:class:`bridgeflap.design.control.formulation.buffeting_term.ModalBuffeting`, the
same frozen-RFA gust transfer, load cross-spectra and closed form in ``K(j omega)`` for a fixed
layout), so::

    sigma_beta^2     = int |K(j omega)|^2 G_alpha_f(omega) d omega
    sigma_betadot^2  = int omega^2 |K(j omega)|^2 G_alpha_f(omega) d omega

The NLP holds ``(SIGMAS sigma_beta / angle_limit)^2 <= 1`` and ``(SIGMAS sigma_betadot /
rate_limit)^2 <= 1`` at every ``actuator_design_speeds_m_s``, for the two flaps of largest demand
at the start design (a mirror pair has the same RMS; the a posteriori usable-speed check of the
acceptance covers every flap and the actuator's servo). The actuator is taken as ideal here
(``beta`` follows ``K alpha``): the card's servo of 10 rad/s passes the structural band
(0.5-3 rad/s) within 2-5 %, which the back-off :data:`DEMAND_BACKOFF` covers.

The quadrature grid is frozen per speed: the union of the adaptive grids of the open loop and of
the start design's closed loop (:func:`bridgeflap.model.spectral.adaptive_frequency_grid`),
refined near their lightly damped peaks.
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from bridgeflap.design.control.formulation.buffeting_term import _compiled, _eig_point_data
from bridgeflap.design.control.formulation.loop_algebra import k_complex
from bridgeflap.design.control.formulation.spectral_terms import gust_frequency_data, point_symbols

#: peak factor of the flap demand: a Gaussian signal passes 3 sigma 0.27 % of the time (the
#: rule of the acceptance's usable speed, design.assessment.usable_speed.SIGMAS)
SIGMAS = 3.0
#: the NLP holds the demand to this fraction of each limit: the ideal-actuator, frozen-grid
#: integral against the verified one with the servo (a few percent apart, measured in the
#: tests); 5 % below the limit keeps a converged design inside it
DEMAND_BACKOFF = 0.05


_POINTS: dict = {}


def _point_function(n, jacobian=False) -> ca.Function:
    """:func:`_point_expression` (``jacobian``: its Jacobian in ``theta``, 4 x 5, instead)
    compiled (as the buffeting term's point function,
    :data:`bridgeflap.design.control.formulation.buffeting_term.JIT`), or evaluated by CasADi's
    virtual machine when no compiler works; cached per process."""
    key = (int(n), bool(jacobian))
    if key not in _POINTS:
        f = _point_expression(n)
        ins = f.sx_in()
        out = f.call(ins)[0]
        if jacobian:
            out = ca.jacobian(out, ins[0])
        name = f"flap_demand_{'jac' if jacobian else 'point'}_c{int(n)}"
        f = ca.Function(name, ins, [out])
        try:
            f = _compiled(f, reverse=False)[0]
        except Exception:  # noqa: BLE001 - no compiler: the same expression, VM
            pass
        _POINTS[key] = f
    return _POINTS[key]


def _point_expression(n) -> ca.Function:
    """Per frequency: ``[|K|^2 G_1, |K|^2 G_2, w^2 |K|^2 G_1, w^2 |K|^2 G_2]`` for the two
    output rows of the buffeting term's closed form
    (:func:`bridgeflap.design.control.formulation.buffeting_term.point_symbols`)."""
    inputs, (Kr, Ki), (g1, g2) = point_symbols(n)
    om = inputs[1]
    k2 = Kr * Kr + Ki * Ki
    out = ca.vertcat(k2 * g1, k2 * g2, om * om * k2 * g1, om * om * k2 * g2)
    return ca.Function("flap_demand_point", inputs, [out])


class FlapDemand:
    """``theta -> g``: the actuator-demand constraints of a fixed flap layout (module doc).

    ``g`` holds, per speed of ``settings.actuator_design_speeds_m_s``, the scaled angle and rate
    constraints of the two flaps (4 values, ``<= 0`` feasible). :meth:`rms_deg` gives the RMS
    flap angle [deg] and rate [deg/s] of those flaps at a numeric ``theta`` (the frozen
    integral), for records and tests.
    """

    def __init__(self, problem, theta_ref, limits):
        from bridgeflap.model.aero.gust import gust_field
        from bridgeflap.model.aeroelastic.control import Compensator
        from bridgeflap.model.response.buffeting import row_factor
        from bridgeflap.model.structure.loader import load_bridge

        s = problem.settings
        spec = problem.spec if problem.spec is not None else load_bridge(s.bridge)
        model = problem.model
        ol = model.open_loop
        basis = ol.basis
        weights = np.asarray(problem.weights, float)
        self.speeds_m_s = np.asarray(s.actuator_design_speeds_m_s, float)
        self.angle_limit_rad = float(np.deg2rad(limits.angle_deg))
        self.rate_limit_rad_s = float(np.deg2rad(limits.rate_deg_s))
        strip_x = np.asarray(basis.strip_x, float)
        gust = gust_field(spec)
        Pa = np.asarray(model.flaps.phi_a, float)
        _, Vt = row_factor(np.asarray(ol.aero.P_gust, float))
        ref = model.system(Compensator(*(float(v) for v in theta_ref)), weights=weights)
        th = ca.MX.sym("theta", 5)
        point, point_jac = _point_function(basis.n), _point_function(basis.n, jacobian=True)
        rows, jac_rows, self.flaps = [], [], []
        for U in self.speeds_m_s:
            om, X, M = gust_frequency_data(model, gust, Vt, strip_x, float(U),
                                           [ol.A(U), ref.A(U)], positive=True)
            # the two flaps of largest angle demand at the start design (numeric, all flaps)
            pick = self._largest_flaps(Pa, X, M, weights, theta_ref, om,
                                      np.asarray(model.flaps.position_m, float))
            self.flaps.append(pick)
            mu, Hs = _eig_point_data(Pa, X, M, Pa[pick], weights)
            data = (ca.DM(om[None, :]), ca.DM(mu.real.T), ca.DM(mu.imag.T),
                    *[ca.DM(np.hstack(list(h))) for H in Hs for h in (H.real, H.imag)])
            v = point.map(om.size, "serial")(th, *data)
            rows.append(ca.sum2(v))                     # (4, 1): angle^2, angle^2, rate^2 x2
            # the Jacobian as the sum of the points' own (4, 5) Jacobians: (4, 5 n) -> (4, 5)
            jv = point_jac.map(om.size, "serial")(th, *data)
            jac_rows.append(ca.mtimes(jv, ca.DM(np.kron(np.ones((om.size, 1)), np.eye(5)))))
        var = ca.vertcat(*rows) if rows else ca.MX(0, 1)
        jac = ca.vertcat(*jac_rows) if jac_rows else ca.MX(0, 5)
        # the NLP's constraint Jacobian from the points' compiled Jacobians, not from CasADi's
        # AD through the mapped point function (measured on the default card: the AD forward
        # sweep took 5 s to build for every nlpsol and 0.38 s per evaluation, 19x the value;
        # this costs about twice the value)
        out = ca.MX.sym("var", var.sparsity())
        self.jacobian = ca.Function("jac_flap_demand_variance", [th, out], [jac],
                                    ["theta", "out_var"], ["jac_var_theta"])
        self.variance = ca.Function("flap_demand_variance", [th], [var], ["theta"], ["var"],
                                    {"custom_jacobian": self.jacobian, "jac_penalty": 0})
        lim = []
        back = (1.0 - DEMAND_BACKOFF) ** 2
        for _ in self.speeds_m_s:
            lim += [self.angle_limit_rad ** 2, self.angle_limit_rad ** 2,
                    self.rate_limit_rad_s ** 2, self.rate_limit_rad_s ** 2]
        self._scale = np.asarray(lim, float) * back / SIGMAS ** 2

    @staticmethod
    def _largest_flaps(Pa, X, M, weights, theta, om, positions) -> list[int]:
        """The indices of the two flaps of largest RMS angle at ``theta`` (numpy, every flap):
        the largest, and the largest at another distance from mid-span (a mirror flap has the
        same RMS); ties by the lower index."""
        Kr, Ki = k_complex(np.asarray(theta, float), om)
        Kc = np.asarray(Kr) + 1j * np.asarray(Ki)
        N = (X * np.asarray(weights, float)[None, None, :]) @ Pa[None, :, :]
        T = np.linalg.inv(np.eye(N.shape[1])[None] - Kc[:, None, None] * N)
        R = Pa[None] @ T                                   # (n_omega, n_flaps, n)
        var = np.einsum("k,kfi,kij,kfj->f", np.abs(Kc) ** 2, R, M, np.conj(R)).real
        order = [int(i) for i in np.argsort(-var, kind="stable")]
        first = order[0]
        other = [i for i in order if abs(abs(positions[i]) - abs(positions[first])) > 1e-6]
        return [first, other[0] if other else first]

    def constraints(self, th):
        """``SIGMAS^2 var / (limit (1 - DEMAND_BACKOFF))^2 - 1`` (<= 0 feasible)."""
        return self.variance(th) / ca.DM(self._scale) - 1.0

    def fraction(self, theta) -> float:
        """The largest 3 sigma flap angle or rate at ``theta`` over the speeds, as a fraction of
        its limit (the card's limit itself, not the back-off: ``<= 1`` within the limits)."""
        v = np.asarray(self.variance(ca.DM(np.asarray(theta, float))).full()).ravel()
        back = (1.0 - DEMAND_BACKOFF) ** 2
        return float(np.sqrt(np.max(np.maximum(v, 0.0) / self._scale) * back))

    def rms_deg(self, theta) -> np.ndarray:
        """RMS angle [deg] and rate [deg/s] per speed: (n_speeds, 4) (two flaps each)."""
        v = np.asarray(self.variance(ca.DM(np.asarray(theta, float))).full()).ravel()
        return np.rad2deg(np.sqrt(np.maximum(v, 0.0))).reshape(-1, 4)
