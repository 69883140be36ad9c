"""Scales and tolerances of the compensator NLP (:mod:`bridgeflap.design.control.formulation.nlp`),
shared with its cutting-plane loop (:mod:`bridgeflap.design.control.formulation.cuts`) and its dense
verification (:mod:`bridgeflap.design.control.formulation.verification`). A leaf module: the NLP
imports the loop and the check, and they
read these values from here rather than from the NLP (no import cycle)."""

from __future__ import annotations

import numpy as np

#: Scale of theta in the regularisation term (a2 ~ 0.01..1 s^2).
THETA_SCALE = np.array([1.0, 1.0, 1.0, 0.1, 1.0])
#: Damping constraints are ~ 0.01 1/s: multiplied by this [s] to be O(1) for Ipopt.
EIG_SCALE = 100.0
#: Feasibility tolerance of the dense verification [1/s] (Ipopt's constr_viol_tol 1e-6 on the
#: scaled constraint is 1e-8 1/s; 1e-6 1/s leaves room for the eig round-off of ~1e-10 1/s).
VIOLATION_TOL = 1e-6
#: The design model's damping is also checked at ``speed_max_m_s (1 + SPEED_GUARD_REL)`` (a
#: violation there is a cutting plane like any other): the dense check to ``speed_max_m_s`` on
#: the verification model then holds. A real root is not kept off the axis by ``zeta_min``
#: (``Re lambda + zeta_min |lambda| = (1 - zeta_min) lambda`` for ``lambda < 0``), so a design
#: whose top-speed constraint is active holds its divergence root at ``lambda = 0`` exactly at
#: ``speed_max_m_s`` on the design model; the finer verification model then diverges just
#: below it. Measured (quick default card, deck GJ -10 %): 16-mode design held to 78.00 m/s,
#: 30-mode closed-loop divergence at 77.99 m/s: ``unverified``; the 16- and 30-mode crossings
#: of such designs lie 0.005-0.01 m/s apart, 1e-3 (0.078 m/s at 78 m/s) is 8 times that. An
#: inactive top-speed constraint (the default card: 30-mode divergence at 80.62 m/s) meets the
#: guard already and its design is unchanged.
SPEED_GUARD_REL = 1e-3
#: Relative back-off of the gain limit inside the NLP. Ipopt accepts a violation of
#: ``constr_viol_tol = 1e-6`` on ``|K|^2 / L_nlp^2 - 1``, i.e. ``|K| <= L_nlp (1 + 5e-7)``;
#: with ``L_nlp = L (1 - 1e-6)`` a converged sample point is strictly inside ``|K| <= L``, so
#: the a posteriori check ``max_gain <= gain_limit`` needs no tolerance of its own.
GAIN_BACKOFF = 1e-6
#: A gain cut (the peak frequency of a round whose true peak gain broke the limit) is held
#: this much further inside: ``|K| <= L_nlp (1 - GAIN_CUT_BACKOFF)``. The peak moves with theta
#: between rounds, and at 1e-6 the re-solves crept up to the limit from above (measured on a
#: 6-mode box-girder design: true peaks 15.006, 15.001, 15.0002 against 15 in three cut rounds,
#: and the design ended infeasible); 1e-3 (0.015 of a gain of 15) is larger than those misses.
GAIN_CUT_BACKOFF = 1e-3
GAIN_CUT_SCALE = (1.0 - GAIN_CUT_BACKOFF) ** 2
#: Default ``DesignSettings.robust_cut_tol``: robust cuts until ``sigma_max(T) <= gamma_T (1 +
#: tol)`` on the dense grid (verified margin within 1 % of the optimiser's).
#: Default card (``python -m bench.design``): 1e-3 took 563 Ipopt iterations in 6 rounds, 93 s,
#: margin 0.3230; 1e-2 362 in 4 rounds, 76 s, margin 0.3226 (-0.13 %), one design per start.
ROBUST_CUT_TOL = 1e-2
#: Robust cuts added per speed and round: the worst local peaks of sigma_max above gamma_T.
ROBUST_CUTS_PER_SPEED = 2
#: Each robust cut is a cluster ``omega* (1 + k ROBUST_CLUSTER_STEP)``, k = -2..2. The peaks
#: of sigma_max(T) here have relative half-power half-widths >= ~3 % (70 m/s, default design:
#: 2.44 at the peak, 2.13 at -2 %); a single point is escaped by shifting the resonance by a
#: fraction of that, a 1 % spaced cluster bounds the under-read of a shifted peak to ~5 %.
ROBUST_CLUSTER_STEP = 0.01
#: Phase 1 (:meth:`design.control.formulation.nlp.DesignProblem.solve_with_cuts`). From a start that
#: violates the damping constraints the robust epigraph is an obstacle: ``||T(j omega)||`` is
#: infinite where a branch crosses the imaginary axis at a sample frequency, so Ipopt, which must
#: carry an unstable branch across the axis to reach feasibility, drives ``gamma_T`` (the objective)
#: to ~1e2 and stalls there (humber:box from the nominal start: 80 iterations, gamma_T 158). The
#: phase-1 solve drops the epigraph (objective: the regularisation only) and tightens every
#: damping constraint by this [1/s] (1/20 of ``zeta_min |lambda|`` at 0.2 rad/s, the lowest
#: structural frequency, for zeta_min = 0.5 %), so phase 2 starts strictly inside.
FEASIBILITY_BACKOFF_1_S = 5e-5
#: Ipopt barrier parameter of a warm-started re-solve (default 0.1 re-centres the iterate
#: far from the previous solution; 1e-3 keeps it near while staying interior). Only with
#: the monotone barrier update: with the limited-memory Hessian Ipopt's default is the
#: adaptive one, which ignored it on the default card (round 3 of start 0: mu raised from
#: 1e-3 to 12.6 in three iterations, the iterate thrown to gamma_T ~ 70, 150 iterations to
#: the cap at gamma_T 12.0; monotone from the same point: 23 iterations, optimal, 2.80).
WARM_MU_INIT = 1e-3
