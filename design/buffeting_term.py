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
