"""The buffeting term of the design objective as a CasADi callback (forward differences).

``J_buf(p)`` is :meth:`design.nlp.DesignProblem.buffeting_cost` (mean squared RMS ratios to the
open loop, :func:`model.buffeting.buffeting`), evaluated numerically; its Jacobian is a forward
difference with step ``step * max(1, |p_k|)``. Used only when ``weight_buffeting > 0``.
"""

from __future__ import annotations

import casadi as ca
import numpy as np


class BuffetingCost(ca.Callback):
    """``J_buf(p)``: closed-loop buffeting cost of ``problem``, forward-difference Jacobian."""

    def __init__(self, problem, n_p, step=1e-4):
        ca.Callback.__init__(self)
        self._prob = problem
        self._n_p = n_p
        self.step = step
        self._cache = {}
        self._jac = None
        self.construct("buffeting_cost", {})

    def get_n_in(self):
        return 1

    def get_n_out(self):
        return 1

    def get_sparsity_in(self, i):
        return ca.Sparsity.dense(self._n_p, 1)

    def get_sparsity_out(self, i):
        return ca.Sparsity.dense(1, 1)

    def value(self, p):
        p = np.asarray(p, float).ravel()
        key = p.tobytes()
        if key not in self._cache:
            self._cache[key] = self._prob.buffeting_cost(p[:5], p[5:] if p.size > 5 else None)
        return self._cache[key]

    def eval(self, arg):
        return [ca.DM(self.value(arg[0]))]

    def has_jacobian(self):
        return True

    def get_jacobian(self, name, inames, onames, opts):
        parent = self

        class _J(ca.Callback):
            def __init__(self):
                ca.Callback.__init__(self)
                self.construct(name, {})

            def get_n_in(self):
                return 2

            def get_n_out(self):
                return 1

            def get_sparsity_in(self, i):
                return ca.Sparsity.dense(parent._n_p, 1) if i == 0 else ca.Sparsity.dense(1, 1)

            def get_sparsity_out(self, i):
                return ca.Sparsity.dense(1, parent._n_p)

            def eval(self, arg):
                p = np.asarray(arg[0], float).ravel()
                f0 = parent.value(p)
                g = np.zeros(p.size)
                for k in range(p.size):
                    h = parent.step * max(1.0, abs(p[k]))
                    e = np.zeros(p.size)
                    e[k] = h
                    g[k] = (parent.value(p + e) - f0) / h
                return [ca.DM(g[None, :])]

        self._jac = _J()
        return self._jac


class SymbolicBuffeting:
    """``J_buf(theta, w)`` as the CasADi spectral integral of the design card (issue 14 item 6).

    Per buffeting speed ``U``, :func:`model.symbolic.buffeting_rms_function` on the closed-loop
    functions ``A_cl(U, theta, w)``, ``B_gust(U, theta, w)`` of the one assembly: the
    one-sided spectral integral (trapezoid rule, frequency grid and load projection frozen at
    the reference design) of the vertical and the torsional RMS at two fixed strips -- the
    main-span strips where the reference closed loop's RMS is largest. Exactly
    differentiable in the compensator coefficients and the flap weights (CasADi AD), unlike
    :class:`BuffetingCost`. ``J_buf = 0.5 mean_U ((z / z0)^2 + (a / a0)^2)`` with ``z0, a0``
    the same integral with ``K = 0`` (flaps fitted, zero gain).

    Parameters
    ----------
    problem : design.nlp.DesignProblem
    theta_ref, w_ref : array_like
        Reference design (frozen grid, strips): e.g. the start point.
    n_base, peaks_per_mode : int
        Grid of :func:`model.spectral.adaptive_frequency_grid` (coarser than the numpy path:
        one dense 2 n_x solve per frequency in the expression graph).
    """

    def __init__(self, problem, theta_ref, w_ref=None, n_base=40, peaks_per_mode=15):
        from model.buffeting import _main_span_mask, buffeting
        from model.control import Compensator
        from model.gust import gust_field
        from model.spec import load_bridge
        from model.symbolic import buffeting_rms_function

        s = problem.settings
        spec = problem.spec if problem.spec is not None else load_bridge(s.bridge)
        model = problem.model
        fun = model.casadi_functions()
        th0 = np.asarray(theta_ref, float)
        w0 = np.ones(model.n_flaps) if w_ref is None else np.asarray(w_ref, float)
        sys_cl = model.system(Compensator(*(float(v) for v in th0)), weights=w0)
        strip_x = np.asarray(model.open_loop.basis.strip_x, float)
        ns = strip_x.size
        main = _main_span_mask(spec, strip_x)
        ref = buffeting(sys_cl, np.asarray(s.buffeting_speeds_m_s, float), spec=spec,
                        n_modes=int(model.open_loop.basis.n))
        gust = gust_field(spec)
        th, w = ca.MX.sym("theta", 5), ca.MX.sym("w", model.n_flaps)
        k0 = ca.DM([0.0, 0.0, 0.0, float(th0[3]), float(th0[4])])
        terms, self.rows, self.omegas = [], [], []
        for i, U in enumerate(s.buffeting_speeds_m_s):
            jv = int(np.argmax(np.where(main, ref.rms_heave[i], -np.inf)))
            jt = int(np.argmax(np.where(main, ref.rms_pitch[i], -np.inf)))
            f, om = buffeting_rms_function(fun["A_cl"], fun["B_gust"], [ca.DM(th0), ca.DM(w0)],
                                           sys_cl.C_out, strip_x, float(U), gust,
                                           [jv, ns + jt], n_base=n_base,
                                           peaks_per_mode=peaks_per_mode)
            r0 = np.asarray(f(k0, ca.DM(w0)).full()).ravel()
            r = f(th, w)
            terms.append((r[0] / r0[0]) ** 2 + (r[1] / r0[1]) ** 2)
            self.rows.append((jv, ns + jt))
            self.omegas.append(om)
        self.function = ca.Function("J_buf", [th, w], [0.5 * sum(terms) / len(terms)],
                                    ["theta", "w"], ["J_buf"])

    def __call__(self, theta, w):
        return self.function(theta, w)
