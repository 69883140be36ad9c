"""Records of the compensator design: one frozen dataclass per result, units in field names.

Each record's ``to_dict()`` is its part of the ``bridgeflap optimise --json`` contract; the
JSON keys are those of the contract (``status`` for the Ipopt exit status, ``max_violation``
for the dense damping violation of a verification), the fields say their units.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bridgeflap.model.results import strict_json

NAN = float("nan")


@dataclass(frozen=True)
class Verification:
    """Dense a posteriori check of a compensator on one model (``DesignProblem.verify``).

    Attributes
    ----------
    speeds_m_s, abscissa_1_s, violation_1_s : ndarray
        Check grid [m/s], spectral abscissa (every eigenvalue) [1/s] and the largest damping
        measure ``Re lambda + zeta_min |lambda|`` of the movable branches [1/s] (<= 0 meets
        the minimum damping ratio;
        :func:`bridgeflap.design.control.formulation.plant.damping_check`).
    max_violation_1_s : float
        Largest violation [1/s].
    stable_everywhere : bool
    stable_to_m_s : float
        Last speed of the leading stable run of the grid [m/s].
    max_gain : float
        True peak ``sup |K(jw)|`` [rad/rad].
    modes : int
        Retained modes of the checked model.
    step_m_s : float
        Grid step [m/s].
    meets_damping : bool
        ``max_violation_1_s`` within the feasibility tolerance
        (``bridgeflap.design.control.formulation.nlp_tolerances.VIOLATION_TOL``).
    min_damping_ratio : float
        Smallest damping ratio of the movable branches over the grid [-] (-1: a real root
        in the right half-plane).
    min_damping_speed_m_s : float
        Where it occurs [m/s].
    damping_ratio : ndarray
        That smallest damping ratio per speed [-].
    guard_speed_m_s, guard_violation_1_s : float
        The design model's guard speed above the grid [m/s] and the damping measure there
        [1/s] (counted in ``max_violation_1_s`` and ``meets_damping``;
        :data:`bridgeflap.design.control.formulation.nlp_tolerances.SPEED_GUARD_REL`); NaN on a
        model checked without one (the verification model, the scenario bridges).
    """

    speeds_m_s: np.ndarray
    abscissa_1_s: np.ndarray
    violation_1_s: np.ndarray
    max_violation_1_s: float
    stable_everywhere: bool
    stable_to_m_s: float
    max_gain: float
    modes: int
    step_m_s: float
    meets_damping: bool
    min_damping_ratio: float = NAN
    min_damping_speed_m_s: float = NAN
    damping_ratio: np.ndarray | None = None
    guard_speed_m_s: float = NAN
    guard_violation_1_s: float = NAN

    @strict_json
    def to_dict(self) -> dict:
        """The scalar part (the ``verification`` JSON object)."""
        guard = ({} if not np.isfinite(self.guard_speed_m_s) else
                 {"guard_speed_m_s": self.guard_speed_m_s,
                  "guard_violation_1_s": self.guard_violation_1_s})
        return {**guard, "max_violation": self.max_violation_1_s,
                "stable_everywhere": self.stable_everywhere,
                "stable_to_m_s": self.stable_to_m_s, "max_gain": self.max_gain,
                "modes": self.modes, "step_m_s": self.step_m_s,
                "meets_damping": self.meets_damping,
                "min_damping_ratio": self.min_damping_ratio,
                "min_damping_speed_m_s": self.min_damping_speed_m_s,
                "max_abscissa_1_s": float(np.max(self.abscissa_1_s))}


@dataclass(frozen=True)
class RobustMargin:
    """Dense small-gain check ``1 / max_U sup_w sigma_max(T(jw))``
    (:mod:`bridgeflap.design.control.formulation.robust`).

    Attributes
    ----------
    speeds_m_s : ndarray
    t_inf : ndarray
        ``sup_w sigma_max(T)`` per speed [-].
    peak_omega_rad_s : ndarray
        Frequency of that peak per speed [rad/s].
    peaks : tuple
        Per speed, the largest local peaks ``(omega [rad/s], sigma_max [-])``.
    margin : float
        ``1 / max(t_inf)`` [-] (NaN without speeds).
    norm : str
    """

    speeds_m_s: np.ndarray
    t_inf: np.ndarray
    peak_omega_rad_s: np.ndarray
    peaks: tuple
    margin: float
    norm: str = "sigma_max (SVD), peaks polished"

    @property
    def peak(self) -> float:
        """``max(t_inf)`` [-]."""
        return float(np.max(self.t_inf))


@dataclass(frozen=True)
class Solve:
    """One Ipopt solve of the NLP (``DesignProblem.solve``).

    ``theta`` (b2, b1, b0, a2, a1), ``weights`` per flap [-], ``gamma_T`` the Frobenius
    epigraph value [-], ``constraints_eig_1_s`` the top-m damping measures ``Re lambda +
    zeta_min |lambda|`` at the design speeds [1/s] (<= 0 feasible), ``eig_time_per_speed_s``
    one eigen-evaluation per speed [s].
    """

    theta: np.ndarray
    gamma_T: float
    weights: np.ndarray
    ipopt_status: str
    success: bool
    iterations: int
    time_s: float
    objective: float
    constraints_eig_1_s: np.ndarray
    n_speeds: int
    eig_evaluations: int
    eig_time_per_speed_s: float
    history: dict | None = None
    #: the divergence watchdog stopped this warm re-solve
    #: (design.control.formulation.nlp.DIVERGE_LEVEL)
    diverged: bool = False
    #: the solution lies on a bound of the solve's trust region (design.control.formulation.cuts),
    #: which the problem itself does not have: not yet a solution of the design problem
    on_trust_bound: bool = False


@dataclass(frozen=True)
class CutRound:
    """One solve of the cutting-plane loop (``DesignProblem.solve_with_cuts``).

    ``new_speeds``, ``new_gain_cuts``, ``new_robust_cuts``: counts of the cuts this round adds;
    ``dense_t_peak`` the dense ``sigma_max(T)`` peak [-] (NaN when not checked).
    """

    round: int
    ipopt_status: str
    iterations: int
    theta: tuple
    time_s: float
    n_speeds: int
    max_violation_1_s: float
    max_gain: float
    gamma_T_frobenius: float
    dense_t_peak: float
    n_robust_points: int
    n_gain_points: int
    new_speeds: int
    new_gain_cuts: int
    new_robust_cuts: int
    eig_time_per_speed_s: float
    chosen: bool = False
    placement: str | None = None
    #: Ipopt's per-iteration ``obj``, ``inf_pr``, ``inf_du``, ``mu`` (not in the JSON summary;
    #: written to ``ipopt_history.json`` by
    #: :meth:`design.control.results.result.DesignResult.history`)
    history: dict | None = None
    #: multi-model: (variant, speed) damping constraints the round's NLP carried, and the
    #: pairs it adds (design.control.formulation.variants; 0 without variants)
    n_variant_constraints: int = 0
    new_variant_constraints: int = 0
    #: scenarios whose flap-demand constraints the round's NLP carried, and those it adds
    #: (variants.demand_checks; 0 without actuator constraints on scenarios)
    n_demand_scenarios: int = 0
    new_demand_scenarios: int = 0
    #: every scenario's flap demand within the actuator limits at the round's design
    scenario_demand_ok: bool = True
    #: what started this solve: ``"cuts"`` (the first solve, or a re-solve after cuts),
    #: ``"recovery"`` (after a diverged solve: from the last point that met damping and gain,
    #: inside a trust region), ``"trust step"`` (the previous solution lay on its trust
    #: region's bound: re-centred there) or ``"continuation"`` (the previous solve stopped at
    #: its iteration cap: continued with the same cuts) (design.control.formulation.cuts)
    step: str = "cuts"
    #: relative half-width of the solve's trust region on theta (NaN: none)
    trust_radius: float = float("nan")

    @strict_json
    def to_dict(self) -> dict:
        """One entry of ``rounds``."""
        out = {"round": self.round, "status": self.ipopt_status, "iterations": self.iterations,
               "theta": list(self.theta), "time_s": self.time_s, "n_speeds": self.n_speeds,
               "max_violation_1_s": self.max_violation_1_s, "max_gain": self.max_gain,
               "gamma_T_frobenius": self.gamma_T_frobenius, "dense_T_peak": self.dense_t_peak,
               "n_robust_points": self.n_robust_points, "n_gain_points": self.n_gain_points,
               "new_cuts": {"speeds": self.new_speeds, "gain": self.new_gain_cuts,
                            "robust": self.new_robust_cuts,
                            "variant_constraints": self.new_variant_constraints,
                            "demand_scenarios": self.new_demand_scenarios},
               "n_variant_constraints": self.n_variant_constraints,
               "n_demand_scenarios": self.n_demand_scenarios,
               "scenario_demand_ok": self.scenario_demand_ok,
               "eig_time_per_speed_s": self.eig_time_per_speed_s, "chosen": self.chosen,
               "step": self.step, "trust_radius": self.trust_radius}
        if self.placement is not None:
            out["placement"] = self.placement
        return out


@dataclass(frozen=True)
class CutsOutcome:
    """Best round of the cutting-plane loop (``DesignProblem.solve_with_cuts``).

    ``solve`` and ``verification`` of the chosen round, ``robust`` its dense robust check (None
    without robustness), ``rounds`` every round, ``design_speeds_m_s`` and the cuts in force at
    the chosen round, ``robust_bound_holds`` dense peak <= gamma_T within the cut tolerance
    (None without robustness).
    """

    solve: Solve
    verification: Verification
    robust: RobustMargin | None
    rounds: tuple
    chosen_round: int
    design_speeds_m_s: tuple
    gain_ok: bool
    robust_bound_holds: bool | None
    robust_cuts: tuple
    gain_cuts: tuple

    @property
    def theta(self) -> np.ndarray:
        """Chosen coefficients (b2, b1, b0, a2, a1)."""
        return self.solve.theta


@dataclass(frozen=True)
class StartRecord:
    """One multistart run (``bridgeflap.design.control.search.driver.run_start``): solve, cuts,
    verification, margin.

    A failed start has ``ipopt_status`` ``"failed: <reason>"``, ``theta`` None and NaN numbers.

    Attributes
    ----------
    start : int
    theta0, theta : tuple
        Start and solution (b2, b1, b0, a2, a1).
    ipopt_status : str
        Ipopt return status of the chosen round.
    iterations : int
        Ipopt iterations over all rounds.
    max_violation_1_s, stable_to_m_s, stable_everywhere, max_gain :
        Dense check on the design model [1/s], [m/s], -, [rad/rad].
    meets_damping, gain_ok, verified : bool
        ``verified``: every a posteriori check holds, also on the verification model.
    gamma_T_frobenius : float
        Optimiser's epigraph value [-].
    objective : float
        The NLP objective at the chosen round's solution [-] (the design's own objective: the
        starts are ranked by it); NaN for a phase-1 point.
    phase_1_point : bool
        The cuts kept the phase-1 (feasibility) point, whose objective is not the design's.
    dense_t_peak_check_speeds : float
        Dense ``sigma_max(T)`` peak at the robust check speeds [-].
    robust : RobustMargin
        Dense check at ``robust_speeds_m_s`` (the reported margin).
    verification : Verification
        Dense check on the verification model.
    flap_positions_m, design_speeds_m_s, robust_cuts, gain_cuts : tuple
    weights_continuous : tuple or None
        Relaxed flap weights (placement only).
    flap_demand : dict or None
        The 3 sigma flap angle [deg] and rate [deg/s] of the solution at the card's
        ``actuator_design_speeds_m_s`` (the NLP's own frozen spectral integral, ideal
        actuator, the two flaps of largest demand), the limits and ``within_limits``; None
        without actuator constraints.
    actuator_ok : bool
        The flap demand within the card's limits at every actuator design speed (counted
        with the damping and the gain in the design's feasibility).
    """

    start: int
    theta0: tuple
    ipopt_status: str
    success: bool
    time_s: float
    theta: tuple | None = None
    iterations: int = 0
    rounds: tuple = ()
    max_violation_1_s: float = NAN
    stable_to_m_s: float = NAN
    stable_everywhere: bool = False
    max_gain: float = NAN
    meets_damping: bool = False
    gain_ok: bool = False
    verified: bool = False
    gamma_T_frobenius: float = NAN
    objective: float = NAN
    phase_1_point: bool = False
    dense_t_peak_check_speeds: float = NAN
    robust_bound_holds: bool | None = None
    robust: RobustMargin | None = None
    verification: Verification | None = None
    robust_cuts: tuple = ()
    gain_cuts: tuple = ()
    flap_positions_m: tuple = ()
    design_speeds_m_s: tuple = ()
    weights_continuous: tuple | None = None
    nlp_active_speeds_m_s: tuple = ()
    variant_checks: tuple = ()
    #: dense check on the design model (reused by the driver, not serialised)
    design_verification: Verification | None = None
    #: Ipopt's objective value of the chosen round [-] (not serialised:
    # design.control.search.layout_search)
    nlp_objective: float = NAN
    #: damping ratio of the compensator's own poles [-] (design.control.formulation.loop_algebra)
    compensator_damping_ratio: float = NAN
    #: how a placement's layout was rounded (design.control.solve.start.choose_layout)
    layout_choice: dict | None = None
    flap_demand: dict | None = None
    actuator_ok: bool = True

    @property
    def failed(self) -> bool:
        """No design came out of this start."""
        return self.theta is None

    @property
    def cut_rounds(self) -> int:
        """Re-solves after cuts."""
        return max(len(self.rounds) - 1, 0)

    @property
    def robust_margin(self) -> float:
        """Dense small-gain margin [-] (NaN without robustness check)."""
        return self.robust.margin if self.robust is not None else NAN

    @strict_json
    def to_dict(self) -> dict:
        """One entry of ``starts`` (the design speeds excluded)."""
        out = {"start": self.start, "theta0": list(self.theta0)}
        if self.weights_continuous is not None:
            out["weights_continuous"] = list(self.weights_continuous)
        if self.layout_choice is not None:
            out["layout_choice"] = dict(self.layout_choice)
        if self.variant_checks:
            out["variant_checks"] = list(self.variant_checks)
        if self.flap_demand is not None:
            out["flap_demand"] = dict(self.flap_demand)
        if self.failed:
            return out | {"status": self.ipopt_status, "success": self.success,
                          "time_s": self.time_s}
        rob = self.robust
        return out | {
            "theta": list(self.theta), "status": self.ipopt_status, "success": self.success,
            "iterations": self.iterations, "time_s": self.time_s,
            "rounds": [r.to_dict() for r in self.rounds], "cut_rounds": self.cut_rounds,
            "max_violation_1_s": self.max_violation_1_s, "stable_to_m_s": self.stable_to_m_s,
            "stable_everywhere": self.stable_everywhere, "max_gain": self.max_gain,
            "meets_damping": self.meets_damping, "gain_ok": self.gain_ok,
            "compensator_damping_ratio": self.compensator_damping_ratio,
            "verified": self.verified, "gamma_T_frobenius": self.gamma_T_frobenius,
            "objective": self.objective, "phase_1_point": self.phase_1_point,
            "dense_T_peak_check_speeds": self.dense_t_peak_check_speeds,
            "robust_bound_holds": self.robust_bound_holds, "robust_margin": self.robust_margin,
            "robust_T_inf_by_speed": self.t_inf_by_speed(),
            "robust_peak_omega_by_speed": {f"{u:g}": float(o) for u, o in
                                           zip(rob.speeds_m_s, rob.peak_omega_rad_s,
                                               strict=True)},
            "robust_cuts": [list(c) for c in self.robust_cuts],
            "gain_cuts": list(self.gain_cuts),
            "flap_positions_m": list(self.flap_positions_m),
            "verification": self.verification.to_dict()}

    def t_inf_by_speed(self) -> dict:
        """``{speed: sup_w sigma_max(T)}`` of the reported robust check (``{}`` if none)."""
        if self.robust is None:
            return {}
        return {f"{u:g}": float(t) for u, t in zip(self.robust.speeds_m_s, self.robust.t_inf,
                                                  strict=True)}

    def table_row(self, chosen: bool) -> dict:
        """One row of ``start_table``: the start's own optimum (its K, flap count, objective,
        margin at the robust speeds, checks) and whether it was chosen."""
        return {"start": self.start, "status": self.ipopt_status,
                "iterations": self.iterations, "cut_rounds": self.cut_rounds,
                "time_s": self.time_s, "objective": self.objective,
                "phase_1_point": bool(self.phase_1_point),
                "theta": list(self.theta) if self.theta is not None else None,
                "flap_count": len(self.flap_positions_m),
                "robust_margin": self.robust_margin,
                "gamma_T_frobenius": self.gamma_T_frobenius, "max_gain": self.max_gain,
                "meets_damping": bool(self.meets_damping),
                "stable_to_m_s": self.stable_to_m_s,
                "compensator_damping_ratio": self.compensator_damping_ratio,
                "verified": bool(self.verified), "chosen": bool(chosen)}


@dataclass(frozen=True)
class FlapCountCheck:
    """One evenly spaced layout of the flap-count search: ``meets_margin`` is the minimum damping
    on the dense grid of the verification model, same K(s)."""

    flap_count: int
    meets_margin: bool
    stable_everywhere: bool
    stable_to_m_s: float
    max_violation_1_s: float

    @strict_json
    def to_dict(self) -> dict:
        """One entry of ``minimum_flaps.counts``."""
        return {"flap_count": self.flap_count, "meets_margin": self.meets_margin,
                "stable_everywhere": self.stable_everywhere,
                "stable_to_m_s": self.stable_to_m_s,
                "max_violation_1_s": self.max_violation_1_s}


@dataclass(frozen=True)
class FlapCountSearch:
    """Fewest evenly spaced flaps meeting the minimum damping
    (``bridgeflap.design.control.search.driver.minimum_flap_count``).

    ``minimum`` None when no checked count meets it; ``modes`` of the verification model.
    """

    minimum: int | None
    counts: tuple[FlapCountCheck, ...]
    modes: int
    criterion: str = ("damping ratio >= zeta_min of the movable branches on the dense grid, "
                      "same K(s)")

    @strict_json
    def to_dict(self) -> dict:
        """The ``minimum_flaps`` JSON object."""
        return {"minimum": self.minimum, "counts": [c.to_dict() for c in self.counts],
                "modes": self.modes, "criterion": self.criterion}


@dataclass(frozen=True)
class BuffetingComparison:
    """Open- vs closed-loop max RMS buffeting response
    (``bridgeflap.design.control.search.driver.buffeting_comparison``).

    RMS vertical [m] and torsional [rad] response per speed [m/s] on the ``modes``-mode
    verification model; ``status`` ``ok`` or ``failed: <reason>`` (then no numbers).
    """

    status: str
    speeds_m_s: tuple = ()
    modes: int = 0
    open_loop_rms_vertical_m: tuple = ()
    closed_loop_rms_vertical_m: tuple = ()
    open_loop_rms_torsion_rad: tuple = ()
    closed_loop_rms_torsion_rad: tuple = ()

    @strict_json
    def to_dict(self) -> dict:
        """The ``buffeting`` JSON object (only ``status`` for a failure)."""
        if self.status != "ok":
            return {"status": self.status}
        return {"speeds_m_s": list(self.speeds_m_s), "modes": self.modes,
                "open_loop_rms_vertical_m": list(self.open_loop_rms_vertical_m),
                "closed_loop_rms_vertical_m": list(self.closed_loop_rms_vertical_m),
                "open_loop_rms_torsion_rad": list(self.open_loop_rms_torsion_rad),
                "closed_loop_rms_torsion_rad": list(self.closed_loop_rms_torsion_rad)}


@dataclass(frozen=True)
class ParetoPoint:
    """One flap count of the Pareto search
    (``bridgeflap.design.control.search.driver.flap_count_pareto``): K(s) re-optimised for the
    evenly spaced symmetric layout of ``flap_count`` flaps, verified.

    ``verified``: damping and gain on the design model's dense grid and stable on the
    verification model's (the same criterion as a converged design); ``robust_margin`` the
    dense small-gain margin [-]; ``stable_to_m_s`` on the verification model [m/s];
    ``theta`` the re-optimised coefficients.
    """

    flap_count: int
    ipopt_status: str
    verified: bool
    robust_margin: float
    max_gain: float
    min_damping_ratio: float
    stable_to_m_s: float
    iterations: int
    time_s: float
    theta: tuple

    @strict_json
    def to_dict(self) -> dict:
        """One entry of ``pareto.points``."""
        return {"flap_count": self.flap_count, "status": self.ipopt_status,
                "verified": self.verified, "robust_margin": self.robust_margin,
                "max_gain": self.max_gain, "min_damping_ratio": self.min_damping_ratio,
                "stable_to_m_s": self.stable_to_m_s, "iterations": self.iterations,
                "time_s": self.time_s, "theta": list(self.theta)}
