"""The compensator NLP: Ipopt over K(s) (and optionally the flap layout), seed §6.

Problem (docs/methods.md#compensator-design)::

    minimise     w_rob gamma_T + w_buf J_buf(theta)/J_buf(open loop) + w_reg |theta/scale|^2
                 + w_flaps sum(w)/n_flaps
    over         theta = (b2, b1, b0, a2, a1), gamma_T  [and w in [0, 1]^n_flaps if
                 optimise_placement]
    subject to   top-m Re lambda + zeta_min |lambda| <= 0 over the movable branches of
                 A_cl(U_i, theta, w) at every design speed (damping ratio >= zeta_min)
                 ||T(j omega_k, U_j)||_F^2 <= gamma_T^2    robust speeds U_j x frequency grid
                 |K(j omega_k)|^2 <= gain_limit^2          on a frequency grid (and omega -> inf)
                 a2 >= a2_min > 0,  a1 >= a1_min > 0       (stable, proper K)
                 a1 >= 2 zeta_c sqrt(a2)                   (compensator poles damped >= zeta_c)

Robustness: ``T`` is the input complementary sensitivity of the flap loop; the NLP bounds its
Frobenius norm (an upper bound of ``sigma_max``) at ``robust_design_speeds_m_s`` and
``n_robust_omega`` log-spaced frequencies plus the in-vacuo structural frequencies, so
``1/gamma_T`` is a guaranteed lower bound of the small-gain margin at those points
(:mod:`bridgeflap.design.control.formulation.robust`); the true margin is checked on a dense grid
(:meth:`robust_margin`).

Damping. The constraint is a minimum damping ratio ``zeta_min`` (default 0.5 %) of
every eigenvalue the flaps can move, written ``Re lambda + zeta_min |lambda| <= 0`` (continuous
through ``lambda = 0``, where divergence crosses; a real stable root always meets it). The
copies of the RFA lag poles ``-p_i U / b`` (up to 16 identical ones, the spectral abscissa at
most speeds) and of the compensator poles are excluded: no flap moves them, and the former
decay-rate constraint on the top real parts was therefore never active. At ``U = 0`` the lag
states are exactly decoupled (their input is proportional to ``U``) and dropped. The
constraints use :class:`bridgeflap.design.control.formulation.eigen.PolynomialStructuralDamping`
(analytic eigenvalue Jacobians through the one assembly, limited-memory Hessian).

Buffeting. ``J_buf`` is the mean over ``buffeting_speeds_m_s`` of the squared RMS vertical and
torsional deck response (each normalised by its ``K = 0`` value): by default the CasADi spectral
integral in modal coordinates
(:class:`bridgeflap.design.control.formulation.buffeting_term.ModalBuffeting`, exact AD
derivatives); used only when ``weight_buffeting > 0``.

Phase 1 and cutting planes (:meth:`DesignProblem.solve_with_cuts`). From a start that violates
the damping constraints a phase-1 solve without the robust epigraph finds a strictly feasible
point first (``FEASIBILITY_BACKOFF_1_S``; it stops at the first feasible iterate,
:mod:`bridgeflap.design.control.formulation.ipopt_hooks`). Then at most ``cutting_plane_rounds``
warm-started re-solves (monotone barrier from ``WARM_MU_INIT``) of at most ``resolve_max_iter``
iterations: violating speeds of the dense damping
check join the design grid; if the true peak ``Compensator.max_gain()`` exceeds the limit, its
frequency joins the gain grid; dense ``sigma_max(T)`` peaks above ``gamma_T`` join the robust
epigraph, and while the bound fails the dense peak frequency of every check speed is tracked
(joins as well), so the optimiser's margin ``1/gamma_T`` converges to the verified one
(tests: within 1 %). The best round (feasible first, then smallest dense peak, peaks within
``robust_cut_tol`` equal and then a round whose bound holds preferred) is returned and every
round is recorded. A design whose true peak gain exceeds ``gain_limit`` is never
``converged``.

Placement (``optimise_placement``): relaxed weights ``w = S z`` in [0, 1], one per mirror pair
with ``symmetric_layout`` (:attr:`DesignProblem.symmetry`), an optional flap-count budget
``sum(w) <= flap_budget`` and penalty ``weight_flaps``; rounding and the re-solve of K for the
rounded layout are in :mod:`bridgeflap.design.control.search.driver`. Multi-model:
:mod:`bridgeflap.design.control.formulation.variants`.

Multistart, verification on the ``verification_modes`` model, placement rounding and the
result records: :mod:`bridgeflap.design.control.search.driver`; settings:
:mod:`bridgeflap.design.control.settings`.
"""

from __future__ import annotations

import time

import casadi as ca
import numpy as np
import scipy.linalg

from bridgeflap.design.control.formulation.buffeting_term import buffeting_objective
from bridgeflap.design.control.formulation.eigen import PolynomialStructuralDamping, parts_jacobian
from bridgeflap.design.control.formulation.ipopt_hooks import (
    DIVERGE_ITERATIONS,
    DIVERGE_LEVEL,
    IterationCallback,
    signals_deferred,
)
from bridgeflap.design.control.formulation.loop_algebra import k_complex

# the NLP's scales and tolerances (shared with the loop)
from bridgeflap.design.control.formulation.nlp_tolerances import (
    EIG_SCALE,
    FEASIBILITY_BACKOFF_1_S,
    GAIN_BACKOFF,
    GAIN_CUT_SCALE,
    THETA_SCALE,
    WARM_MU_INIT,
)
from bridgeflap.design.control.formulation.plant import (
    compensator_reduction,
    damping_check,
    lag_free_indices,
    lag_rates,
)
from bridgeflap.design.control.formulation.robust import (
    robust_dense_omega,
    robust_margin,
)
from bridgeflap.design.control.formulation.variants import demand_constraints, speeds_of
from bridgeflap.design.control.results.records import CutsOutcome, RobustMargin, Solve, Verification
from bridgeflap.design.control.settings import DesignSettings
from bridgeflap.model.aeroelastic.control import Compensator

#: Damping constraints and dense checks on the closed loop without the per-flap compensator
#: copies (:func:`design.control.formulation.plant.compensator_reduction`, exact): 146 -> 104 states
#: on the default card, 230 -> 200 on its 30-mode check (closed-loop limits: the full state).
REDUCE_COMPENSATORS = True


class DesignProblem:
    """Compensator NLP for a flap layout (build once, solve from many starts).

    Parameters
    ----------
    settings : DesignSettings
    model : bridgeflap.model.aeroelastic.flaps.ClosedLoopModel
    weights : array_like, optional
        Per-flap weights [0, 1] (1 = fitted); the start point when ``optimise_placement``.
    spec : bridgeflap.model.structure.spec.BridgeSpec, optional
        Needed only for the buffeting term (wind defaults).
    numeric : bool
        Checks only (:meth:`verify`, :meth:`A_parts`): the closed-loop parts come from the
        numeric :meth:`bridgeflap.model.aeroelastic.flaps.ClosedLoopModel.system` (same assembly,
        equal to round-off) and the symbolic closed loop is never built (1.2-1.7 s on 16-30 modes,
        more than the dense check's eigenvalues on 16); solving needs ``numeric=False``.
    """

    def __init__(self, settings: DesignSettings, model, weights=None, spec=None,
                 numeric=False):
        self.settings = settings
        self.model = model
        self.spec = spec
        self.numeric = bool(numeric)
        self.weights = (np.ones(model.n_flaps) if weights is None
                        else np.asarray(weights, float).ravel())
        self._functions = None
        self._keep0 = None
        self._reduction = None
        self.callbacks: dict = {}      # kept alive (design.control.formulation.eigen docstring)
        self._robust = None
        self._robust_base = None
        self._buffeting_ref = None
        #: Cutting planes added by :meth:`solve_with_cuts`: robust (speed, omega) points and
        #: gain-constraint frequencies, on top of the settings' sample grids.
        self.robust_cuts: list[tuple[float, float]] = []
        self.gain_cuts: list[float] = []
        #: ``(iteration, objective, x) -> None`` called once per Ipopt iteration (progress).
        self.on_iteration = None
        #: Multi-model: bridge-variant problems (same layout, settings;
        #: design.control.formulation.variants)
        self.variants: list[DesignProblem] = []
        self.lazy_speeds: list[float] = []   # a variant's own damping speeds (ditto)
        #: A scenario variant's flap-demand constraints: None (a problem that carries none:
        #: the nominal one, a failed-pair variant), False (checked after each round, not in
        #: the NLP) or True (in the NLP; variants.demand_checks)
        self.demand_held: bool | None = None
        #: The damping is checked at ``speed_max_m_s (1 + speed_guard_rel)`` too (0: not;
        #: design.control.formulation.verification.verify): set on a start's design model only
        self.speed_guard_rel = 0.0

    @property
    def functions(self) -> dict:
        """The symbolic closed loop
        (:meth:`bridgeflap.model.aeroelastic.flaps.ClosedLoopModel.casadi_functions`)."""
        if self._functions is None:
            self._functions = self.model.casadi_functions()
        return self._functions

    @property
    def keep0(self) -> np.ndarray:
        """Closed-loop states kept at ``U = 0`` (no lag states)."""
        if self._keep0 is None:
            self._keep0 = lag_free_indices(self.model)
        return self._keep0

    @property
    def keep0_constraints(self) -> np.ndarray:
        """:attr:`keep0` on the (reduced) state of the damping constraints."""
        red = self.reduction(self.functions["A_cl"].size1_out(0))
        return self.keep0 if red is None else red[2]

    def reduction(self, nx):
        """:func:`bridgeflap.design.control.formulation.plant.compensator_reduction` of this model
        (None: not reduced)."""
        if not REDUCE_COMPENSATORS:
            return None
        if self._reduction is None or self._reduction[0] != nx:
            self._reduction = (nx, compensator_reduction(self.model, nx))
        return self._reduction[1]

    @property
    def symmetry(self) -> np.ndarray:
        """``S`` (n_flaps, n_z) with ``w = S z``: with ``symmetric_layout`` the flap at ``x`` and
        its mirror at ``-x`` share one weight (the layout's positions are symmetric about
        mid-span, sorted), otherwise the identity."""
        nF = self.model.n_flaps
        if not self.settings.symmetric_layout:
            return np.eye(nF)
        pos = np.asarray(self.model.flaps.position_m, float)
        order = np.argsort(pos)
        if not np.allclose(pos[order], -pos[order][::-1], atol=1e-6):
            return np.eye(nF)           # not a symmetric layout: independent weights
        nz = (nF + 1) // 2
        S = np.zeros((nF, nz))
        for r, i in enumerate(order):
            S[i, min(r, nF - 1 - r)] = 1.0
        return S

    @property
    def n_z(self) -> int:
        """Placement variables: one weight per flap, or per mirror pair (symmetric)."""
        return self.symmetry.shape[1]

    def z_of(self, weights) -> np.ndarray:
        """Placement variables of per-flap ``weights`` (least squares through ``S``)."""
        S = self.symmetry
        return np.linalg.lstsq(S, np.asarray(weights, float), rcond=None)[0]

    @property
    def n_p(self) -> int:
        """Number of callback parameters: theta, plus the placement variables when free."""
        return 5 + (self.n_z if self.settings.optimise_placement else 0)

    # ---- pieces
    def parts_function(self) -> ca.Function:
        """``p -> (A0, A1, A2)`` with ``p = theta`` or ``(theta, w)`` (placement), built once,
        with its Jacobian (:func:`bridgeflap.design.control.formulation.eigen.parts_jacobian`,
        shared by every grid)."""
        if self.callbacks.get("parts") is None:
            self.callbacks["parts"] = (f := self._parts_function(), parts_jacobian(f))
        return self.callbacks["parts"][0]

    def _parts_function(self) -> ca.Function:
        th = ca.SX.sym("theta", 5)
        if self.settings.optimise_placement:
            z = ca.SX.sym("z", self.n_z)
            p = ca.vertcat(th, z)
            parts = self.functions["A_parts"](th, ca.mtimes(ca.DM(self.symmetry), z))
        else:
            p = th
            parts = self.functions["A_parts"](th, ca.DM(self.weights))
        red = self.reduction(self.functions["A_cl"].size1_out(0))
        if red is not None:         # the per-flap compensator copies dropped (exact)
            T, Tl = ca.DM(red[0]), ca.DM(red[1])
            parts = [ca.mtimes(Tl, ca.mtimes(a, T)) for a in parts]
        return ca.Function("A_parts_p", [p], list(parts))

    def grid_callback(self, speeds) -> PolynomialStructuralDamping:
        """Top-m damping measures of the movable branches at ``speeds`` (lag states dropped at
        U = 0), cached per grid."""
        key = tuple(float(u) for u in speeds)
        if key not in self.callbacks:
            self.callbacks[key] = PolynomialStructuralDamping(
                self.parts_function(), np.array(key), self.settings.n_eig,
                lag_rates(self.model), self.settings.zeta_min,
                subsets={0.0: self.keep0_constraints},
                name=f"damping_grid_{len(self.callbacks)}",
                dparts=self.callbacks["parts"][1])
        return self.callbacks[key]

    def A_parts(self, theta, weights=None) -> tuple:
        """Numeric ``(A0, A1, A2, keep0)`` of the closed loop at ``theta``."""
        w = self.weights if weights is None else np.asarray(weights, float)
        if self.numeric:
            sc = self.model.system(Compensator(*(float(v) for v in theta)), weights=w)
            keep = np.ones(sc.n_states, bool)
            keep[sc.index.aero_lag] = False
            return sc.A0, sc.A1, sc.A2, np.flatnonzero(keep)
        A0, A1, A2 = self.functions["A_parts"](ca.DM(theta), ca.DM(w))
        return A0.full(), A1.full(), A2.full(), self.keep0

    def omega_grid(self) -> np.ndarray:
        """Frequency grid of the gain constraint [rad/s]: log grid plus the gain cuts."""
        s = self.settings
        w = np.logspace(np.log10(s.omega_min_rad_s), np.log10(s.omega_max_rad_s), s.n_omega)
        return np.unique(np.concatenate([w, np.asarray(self.gain_cuts, float)]))

    def structural_frequencies(self) -> np.ndarray:
        """In-vacuo structural circular frequencies [rad/s]."""
        B = self.model.open_loop.basis
        return np.sqrt(np.abs(scipy.linalg.eigvals(B.K, B.M).real))

    def robust_omega_grid(self) -> np.ndarray:
        """Frequencies of the robustness constraint [rad/s]: log grid + structural modes."""
        s = self.settings
        w = np.logspace(np.log10(s.robust_omega_min_rad_s), np.log10(s.robust_omega_max_rad_s),
                        s.n_robust_omega)
        ws = self.structural_frequencies()
        ws = ws[(ws > s.robust_omega_min_rad_s) & (ws < s.robust_omega_max_rad_s)]
        # the peaks of |T| sit on the lightly damped closed-loop modes: a linear band over
        # the structural frequency range as well (n_robust_omega points)
        band = np.linspace(0.8 * ws.min(), 1.2 * ws.max(), s.n_robust_omega) if ws.size else []
        return np.unique(np.concatenate([w, ws, band]))

    def robust_check_speeds(self) -> np.ndarray:
        """Speeds of the dense robust check and cuts [m/s]: design and reported speeds."""
        s = self.settings
        return np.unique(np.asarray(tuple(s.robust_design_speeds_m_s)
                                    + tuple(s.robust_speeds_m_s), float))

    def robust_function(self, analytic=False) -> tuple[ca.Function, list]:
        """``(theta, w) -> ||T||_F^2`` at every (robust design speed, frequency) and at every
        robust cut (:attr:`robust_cuts`), and the ``(speed, omega)`` points.

        ``analytic``: the layout ``w`` is fixed at :attr:`weights` (the ``w`` argument is
        ignored) and ``T`` is a closed-form expression of the scalar ``K(j omega)`` per point
        (:func:`bridgeflap.design.control.formulation.robust.analytic_robust_data`; same values to
        round-off, ~10x cheaper Jacobian); the points are then ordered diagonalised first."""
        from bridgeflap.design.control.formulation.robust import robust_epigraph_function

        return robust_epigraph_function(self, analytic)

    # ---- actuator demand
    def flap_demand(self, theta_ref=None):
        """The actuator-demand constraints of this layout (:class:`~bridgeflap.design.control.\
formulation.actuator_demand.FlapDemand`), built once, frozen at ``theta_ref`` (the first call's)."""
        if self.callbacks.get("flap_demand") is None:
            if theta_ref is None:
                raise ValueError("flap_demand: theta_ref is needed to build the constraints")
            from bridgeflap.design.control.formulation.actuator_demand import FlapDemand
            from bridgeflap.model.aeroelastic.actuator_limits import ActuatorLimits

            s = self.settings
            lim = ActuatorLimits(s.flap_angle_limit_deg, s.flap_rate_limit_deg_s)
            self.callbacks["flap_demand"] = FlapDemand(
                self, np.asarray(theta_ref, float), lim)
        return self.callbacks["flap_demand"]

    # ---- buffeting
    def buffeting_rms(self, theta, weights=None, speeds=None) -> tuple[np.ndarray, np.ndarray]:
        """Max RMS vertical [m] and torsional [rad] response at ``speeds`` (closed loop)."""
        from bridgeflap.model.response.buffeting import buffeting
        from bridgeflap.model.structure.loader import load_bridge

        spec = self.spec if self.spec is not None else load_bridge(self.settings.bridge)
        w = self.weights if weights is None else np.asarray(weights, float)
        speeds = self.settings.buffeting_speeds_m_s if speeds is None else speeds
        sys_cl = self.model.system(Compensator(*(float(v) for v in theta)), weights=w)
        r = buffeting(sys_cl, np.asarray(speeds, float), spec=spec,
                      n_modes=int(self.model.open_loop.basis.n))
        return r.rms_vertical, r.rms_torsion

    def buffeting_cost(self, theta, weights=None) -> float:
        """``J_buf``: mean of the squared RMS ratios to the open loop (NaN/unstable -> 1e3).
        ``weights``: per flap, or the placement variables ``z`` (expanded by ``S``)."""
        if weights is not None and len(weights) != self.model.n_flaps:
            weights = self.symmetry @ np.asarray(weights, float)
        if self._buffeting_ref is None:
            self._buffeting_ref = self.buffeting_rms([0.0, 0.0, 0.0, 1.0, 1.0])
        try:
            ok = theta[3] > 0 and theta[4] > 0
            z, a = self.buffeting_rms(theta, weights) if ok else (np.nan, np.nan)
        except Exception:  # noqa: BLE001 - infeasible iterate: a large finite cost
            return 1e3
        z0, a0 = self._buffeting_ref
        v = 0.5 * np.mean((np.asarray(z) / z0) ** 2 + (np.asarray(a) / a0) ** 2)
        return float(v) if np.isfinite(v) else 1e3

    def constraint_values(self, theta, speeds, weights=None) -> np.ndarray:
        """Largest damping measure ``Re lambda + zeta_min |lambda|`` of the movable branches per
        speed (n_speeds,) [1/s]; <= 0 is feasible."""
        return damping_check(self.A_parts(theta, weights), speeds, lag_rates(self.model), theta,
                             self.settings.zeta_min)["measure_1_s"]

    # ---- one solve
    def solve(self, theta0, speeds, max_iter=None, weights0=None, gamma0=None,
              warm=False, feasibility=False, trust=None) -> Solve:
        """Solve the NLP from ``theta0`` (and ``weights0``) on the design ``speeds`` [m/s].

        ``gamma0`` (warm start) is raised to the epigraph value at ``theta0`` when lower, so
        the start satisfies the robust constraints whatever cuts were added; ``warm``
        starts Ipopt's barrier at ``WARM_MU_INIT`` (a re-solve after cuts). ``feasibility``:
        phase 1 -- no robust epigraph, damping constraints tightened by
        ``FEASIBILITY_BACKOFF_1_S`` (see there). ``trust = (centre, radius)``: theta is held
        within ``centre +- radius max(|centre|, THETA_SCALE)`` (a trust region, intersected with
        the bounds; :mod:`bridgeflap.design.control.formulation.cuts`). Returns a
        :class:`bridgeflap.design.control.results.records.Solve`.
        """
        s = self.settings
        nF = self.model.n_flaps
        speeds = np.asarray(speeds, float)
        th = ca.MX.sym("theta", 5)
        gT = ca.MX.sym("gamma_T")
        if s.optimise_placement:
            z = ca.MX.sym("z", self.n_z)
            w = ca.mtimes(ca.DM(self.symmetry), z)
            p = ca.vertcat(th, z)
            x = ca.vertcat(th, gT, z)
        else:
            w = ca.DM(self.weights)
            p = th
            x = ca.vertcat(th, gT)
        cb = self.grid_callback(speeds)
        n_eig_cons = len(speeds) * s.n_eig
        g = [EIG_SCALE * cb(p)]
        lbg = [np.full(n_eig_cons, -np.inf)]
        ubg = [np.full(n_eig_cons, -EIG_SCALE * FEASIBILITY_BACKOFF_1_S if feasibility else 0.0)]
        # gain limit |K(j w)| <= L_nlp on the grid (+ gain cuts, GAIN_CUT_BACKOFF), at omega = 0
        # (b0) and at omega -> inf (b2/a2); L_nlp backed off by GAIN_BACKOFF (see there)
        L2 = (s.gain_limit * (1.0 - GAIN_BACKOFF)) ** 2
        oms, cut = self.omega_grid(), set(self.gain_cuts)
        for om in oms:
            Kr, Ki = k_complex(th, om)
            g.append((Kr * Kr + Ki * Ki) / (L2 * GAIN_CUT_SCALE if om in cut else L2) - 1.0)
        g.append(th[2] * th[2] / L2 - 1.0)
        # omega -> inf as (b2/a2)^2 / L^2 - 1 (a2 >= a2_min > 0): scaled like the grid
        # points, so constr_viol_tol bounds the relative gain error (not a2^2 times it)
        g.append(th[0] * th[0] / (th[3] * th[3] * L2) - 1.0)
        lbg.append(np.full(len(oms) + 2, -np.inf))
        ubg.append(np.zeros(len(oms) + 2))
        if s.compensator_damping_min > 0:
            # the compensator's own poles (a2 s^2 + a1 s + 1 = 0) damped at least
            # compensator_damping_min: a1 >= 2 zeta_c sqrt(a2), written relative to a1 so that
            # constr_viol_tol bounds the relative damping error. A lightly damped compensator
            # pole beside a structural frequency is a resonance that helps the nominal bridge
            # and harms a variant whose mode moves into it (docs/methods.md)
            g.append(2.0 * s.compensator_damping_min * ca.sqrt(th[3]) / th[4] - 1.0)
            lbg.append(np.array([-np.inf]))
            ubg.append(np.zeros(1))
        f = s.weight_regularisation * ca.sumsqr(th / THETA_SCALE)
        n_rob = 0
        if (s.weight_robust > 0 and (s.robust_design_speeds_m_s or self.robust_cuts)
                and not feasibility):
            rob, pts = self.robust_function(analytic=not s.optimise_placement)
            g.append(rob(th, w) - gT * gT)
            n_rob = len(pts)
            lbg.append(np.full(n_rob, -np.inf))
            ubg.append(np.zeros(n_rob))
            f = f + s.weight_robust * gT
        if s.weight_buffeting > 0 and not feasibility:   # phase 1: feasibility only
            f = f + s.weight_buffeting * buffeting_objective(self, theta0, weights0, th, w, p)
        if s.actuator_design_speeds_m_s and not feasibility and not s.optimise_placement:
            # the 3 sigma flap angle and rate within the actuator's limits (actuator_demand)
            dem = self.flap_demand(theta0)
            g.append(dem.constraints(th))
            n_dem = 4 * len(dem.speeds_m_s)
            lbg.append(np.full(n_dem, -np.inf))
            ubg.append(np.zeros(n_dem))
        if not feasibility:         # the held scenarios' flap demand (variants.demand_checks)
            demand_constraints(self, th, g, lbg, ubg)
        if s.optimise_placement and s.weight_flaps > 0:
            f = f + s.weight_flaps * ca.sum1(w) / nF
        if s.optimise_placement and s.flap_budget > 0:
            # flap-count budget: sum of the relaxed weights <= flap_budget (linear)
            g.append(ca.sum1(w) - float(s.flap_budget))
            lbg.append(np.array([-np.inf]))
            ubg.append(np.zeros(1))
        lbx = [-s.b_bound, -s.b_bound, -s.b_bound, s.a2_bounds[0], s.a1_bounds[0], 0.0]
        ubx = [s.b_bound, s.b_bound, s.b_bound, s.a2_bounds[1], s.a1_bounds[1], 1e4]
        theta0 = np.asarray(theta0, float)
        tr_lo = tr_hi = None
        if trust is not None:       # the trust region, inside the problem's own bounds
            c = np.asarray(trust[0], float)
            half = float(trust[1]) * np.maximum(np.abs(c), THETA_SCALE)
            tr_lo = np.maximum(np.asarray(lbx[:5], float), c - half)
            tr_hi = np.minimum(np.asarray(ubx[:5], float), c + half)
            lbx[:5], ubx[:5] = list(tr_lo), list(tr_hi)
            theta0 = np.clip(theta0, tr_lo, tr_hi)
        w0 = self.weights if weights0 is None else np.asarray(weights0, float)
        gT0 = 1.0
        if n_rob:
            vals = np.asarray(rob(theta0, w0).full()).ravel()
            gT0 = float(np.sqrt(np.max(vals))) if np.all(np.isfinite(vals)) else 10.0
            gT0 = min(max(gT0, 1e-3, 0.0 if gamma0 is None else float(gamma0)), 1e3)
        x0 = np.append(theta0, gT0)
        if s.optimise_placement:
            lbx += [0.0] * self.n_z
            ubx += [1.0] * self.n_z
            x0 = np.append(x0, np.clip(self.z_of(w0), 0.0, 1.0))
        for v in self.variants:     # multi-model: a variant's damping speeds (variants)
            vs = speeds_of(v, speeds)
            if vs.size:
                g.append(EIG_SCALE * v.grid_callback(vs)(p))
                lbg.append(np.full(vs.size * s.n_eig, -np.inf))
                ubg.append(np.full(vs.size * s.n_eig, -EIG_SCALE * FEASIBILITY_BACKOFF_1_S
                                   if feasibility else 0.0))
        nlp = {"x": x, "f": f, "g": ca.vertcat(*g)}
        opts = {"ipopt.hessian_approximation": "limited-memory",
                "ipopt.max_iter": int(max_iter or s.max_iter), "ipopt.print_level": 0,
                "print_time": False, "ipopt.tol": 1e-6, "ipopt.acceptable_tol": 1e-4,
                "ipopt.acceptable_iter": 5, "ipopt.sb": "yes", "ipopt.constr_viol_tol": 1e-6,
                # an "acceptable" exit must be as feasible as an optimal one (default 1e-2)
                "ipopt.acceptable_constr_viol_tol": 1e-6}
        if warm:
            opts["ipopt.mu_init"] = WARM_MU_INIT
            opts["ipopt.mu_strategy"] = "monotone"
        watch = None
        if warm and not feasibility and DIVERGE_ITERATIONS > 0:
            watch = (np.concatenate(lbg), np.concatenate(ubg), DIVERGE_LEVEL,
                     DIVERGE_ITERATIONS)
        # always: it stops Ipopt on Ctrl-C/SIGTERM; phase 1 stops at its first feasible
        # iterate, a warm re-solve when it diverges (design.control.formulation.ipopt_hooks)
        it_cb = IterationCallback("design_iterations", x.size1(), nlp["g"].size1(),
                                  self.on_iteration,
                                  np.concatenate(ubg) if feasibility else None, watch)
        self.callbacks["iterations"] = it_cb
        opts["iteration_callback"] = it_cb
        solver = ca.nlpsol("design", "ipopt", nlp, opts)
        ev0, et0 = cb.evaluations, cb.eval_time_s
        t0 = time.perf_counter()
        with signals_deferred():    # an interrupted solve raises here, never returns a design
            sol = solver(x0=x0, lbx=lbx, ubx=ubx, lbg=np.concatenate(lbg),
                         ubg=np.concatenate(ubg))
        elapsed = time.perf_counter() - t0
        st = solver.stats()
        xs = np.asarray(sol["x"].full()).ravel()
        gs = np.asarray(sol["g"].full()).ravel()
        evals = cb.evaluations - ev0
        on_trust_bound = False
        if trust is not None:       # a trust-region bound active (not one of the problem's)
            own_lo = np.array([-s.b_bound] * 3 + [s.a2_bounds[0], s.a1_bounds[0]])
            own_hi = np.array([s.b_bound] * 3 + [s.a2_bounds[1], s.a1_bounds[1]])
            tol = 1e-4 * (tr_hi - tr_lo)    # Ipopt ends ~3e-6 of the width inside a bound
            on_trust_bound = bool(np.any((xs[:5] <= tr_lo + tol) & (tr_lo > own_lo))
                                  or np.any((xs[:5] >= tr_hi - tol) & (tr_hi < own_hi)))
        its = st.get("iterations", {})
        history = {k: [float(v) for v in its[k]] for k in ("obj", "inf_pr", "inf_du", "mu")
                   if k in its}
        if watch is not None:       # the watchdog's measure per iteration (NLP units)
            history["max_violation"] = [float(v) for v in it_cb.violations]
        return Solve(theta=xs[:5], gamma_T=float(xs[5]),
                     weights=(self.symmetry @ xs[6:] if s.optimise_placement
                              else self.weights.copy()),
                     ipopt_status=st["return_status"] + (
                         " (phase 1: first feasible iterate)" if feasibility
                         and it_cb.stopped_feasible else "") + (
                         f" (diverged: constraint violation above {DIVERGE_LEVEL:g} for "
                         f"{DIVERGE_ITERATIONS} iterations)"
                         if it_cb is not None and it_cb.stopped_diverged else ""),
                     diverged=bool(it_cb is not None and it_cb.stopped_diverged),
                     on_trust_bound=on_trust_bound,
                     success=bool(st["success"]),
                     iterations=int(st["iter_count"]), time_s=elapsed,
                     objective=float(sol["f"]),
                     constraints_eig_1_s=gs[:n_eig_cons] / EIG_SCALE, n_speeds=len(speeds),
                     eig_evaluations=evals,
                     eig_time_per_speed_s=(cb.eval_time_s - et0) / max(evals, 1) / len(speeds),
                     history=history)

    # ---- verification
    def verify(self, theta, weights=None, refined=False) -> Verification:
        """Dense a posteriori check on the check grid: abscissa (every eigenvalue), damping of
        the movable branches, peak gain
        (:func:`bridgeflap.design.control.formulation.verification.verify`; ``refined``: on the
        subset of :func:`bridgeflap.design.control.formulation.plant.damping_check_refined`)."""
        from bridgeflap.design.control.formulation.verification import verify

        return verify(self, theta, weights, refined)

    def solve_with_cuts(self, theta0, weights0=None) -> CutsOutcome:
        """Solve and re-solve with cutting planes (at most ``cutting_plane_rounds`` re-solves).

        After each solve the design is checked a posteriori and the worst violations join the
        NLP's sample sets before a warm-started re-solve:

        * damping: the movable branches on the dense ``check_step_m_s`` grid; the worst speed
          of each run of violations joins the design speeds;
        * gain limit: the true peak
          :meth:`bridgeflap.model.aeroelastic.control.Compensator.max_gain`; if above ``gain_limit``
          the stationary frequencies of ``|K(jw)|`` join the gain grid;
        * robustness: ``sigma_max(T)`` on a dense frequency grid (:meth:`robust_margin`) at
          :meth:`robust_check_speeds`; the worst (speed, frequency) peaks above
          ``gamma_T (1 + robust_cut_tol)`` join the robust epigraph points.

        Returns the :class:`bridgeflap.design.control.results.records.CutsOutcome` of the best
        round: its solve, verification and dense robust check, every round, the design speeds and
        cuts then in force, ``gain_ok`` and ``robust_bound_holds`` (dense peak <= gamma_T within
        ``robust_cut_tol``).
        """
        from bridgeflap.design.control.formulation.cuts import solve_with_cuts

        return solve_with_cuts(self, theta0, weights0)

    # ---- robustness
    def robust_dense_omega(self, theta, U, weights=None) -> np.ndarray:
        """Dense check frequencies [rad/s] at speed ``U`` [m/s] of the closed loop at ``theta``
        (:func:`bridgeflap.design.control.formulation.robust.robust_dense_omega`)."""
        return robust_dense_omega(self.A_parts(theta, weights), U, self.structural_frequencies())

    def robust_margin(self, theta, speeds=None, omega=None, weights=None,
                      peaks=1) -> RobustMargin:
        """True small-gain margin on a dense grid
        (:func:`bridgeflap.design.control.formulation.robust.robust_margin`).

        Default grid: ``robust_speeds_m_s`` x :meth:`robust_dense_omega`, or the fixed
        frequencies ``omega`` [rad/s] at every speed; ``peaks`` local peaks kept per speed.
        """
        speeds = self.settings.robust_speeds_m_s if speeds is None else speeds
        w = self.weights if weights is None else np.asarray(weights, float)
        theta = np.asarray(theta, float)

        def omega_at(U):
            return (self.robust_dense_omega(theta, U, w) if omega is None
                    else np.asarray(omega, float))

        return robust_margin(self.model, theta, speeds, w, omega_at, peaks=peaks,
                             cache=self.callbacks.setdefault("plant factors", {}))
