"""The outcome of a compensator design: :class:`DesignResult`, its JSON summary and plots."""

from __future__ import annotations

from dataclasses import asdict, dataclass, field

import numpy as np

from bridgeflap.design.control.results.records import FlapCountSearch, StartRecord
from bridgeflap.design.control.settings import CRITICAL_SPEED_FIELDS, THETA_NAMES, DesignSettings
from bridgeflap.model.aeroelastic.actuator_limits import ACTUATOR_DEFAULTS, ACTUATOR_FIELDS
from bridgeflap.model.aeroelastic.control import Controller
from bridgeflap.model.results import ResultData, jsonable

NAN = float("nan")


@dataclass(frozen=True)
class DesignResult(ResultData):
    """Outcome of :func:`bridgeflap.design.control.search.driver.design`.

    Attributes
    ----------
    status : str
        ``converged``, ``unverified``, ``infeasible`` or ``failed``
        (:func:`bridgeflap.design.control.search.driver.select_start`); after the acceptance checks
        of :func:`bridgeflap.design.assessment.accept.design` also ``harm``, ``failed_checks`` (the
        independent check disagrees, or the usable speed is not above the open-loop critical
        speed) or ``unresolved``. Only ``converged`` carries a ``controller``.
    settings : DesignSettings
    controller : bridgeflap.model.aeroelastic.control.Controller or None
        The designed compensator and layout, **only when** ``status == "converged"`` (it met
        every check); None otherwise, so that an unusable design is never handed on.
    candidate : bridgeflap.model.aeroelastic.control.Controller or None
        The best start's compensator and layout whatever the status (for diagnosis only: a
        candidate of a failed design did not pass its checks).
    starts : tuple of StartRecord
        Every start, in order.
    best : StartRecord or None
        The chosen start.
    abscissa_speeds_m_s, abscissa_1_s : ndarray
        Dense check grid [m/s] and the chosen design's spectral abscissa on the verification
        model [1/s] (NaN without a design).
    min_flaps : FlapCountSearch or None
        Fewest evenly spaced flaps meeting the minimum damping
        (:func:`bridgeflap.design.control.search.driver.minimum_flap_count`; None when not
        searched: no design, or a placed layout, whose fewest strips
        :func:`bridgeflap.design.control.search.placement.placement_search` answers).
    wall_time_s : float
    extras : dict
        ``open_loop_abscissa`` [1/s], ``closed_loop`` (state space), ``buffeting``
        (:class:`bridgeflap.design.control.results.records.BuffetingComparison`),
        ``response_by_speed`` (the paper's Fig. 5 right as rows,
        :mod:`bridgeflap.design.assessment.usable_speed`).

    The headline is :attr:`usable_speed_m_s` (with :attr:`usable_speed_limited_by`) beside
    :attr:`open_loop_critical_speed_m_s`; :attr:`closed_loop_critical_speed_m_s` is the linear
    closed loop's, with ideal actuators.
    """

    status: str
    settings: DesignSettings
    controller: Controller | None
    candidate: Controller | None
    starts: tuple[StartRecord, ...]
    best: StartRecord | None
    abscissa_speeds_m_s: np.ndarray
    abscissa_1_s: np.ndarray
    min_flaps: FlapCountSearch | None
    wall_time_s: float
    extras: dict = field(default_factory=dict, compare=False)

    def summary(self) -> dict:
        """Strict-JSON summary (the ``bridgeflap optimise`` contract; not-a-number -> None).

        Returns
        -------
        dict
            Strict-JSON numbers and statuses, units in the key names: the status, the
            coefficients of ``K(s)``, the flap layout, the usable and critical speeds [m/s], the
            gain and the robust margin, the verification and, when they ran, the acceptance
            checks; ``None`` where a number was not computed.
        """
        k = self.candidate.compensator if self.candidate else None
        coeffs = ({n: getattr(k, n) for n in THETA_NAMES} if k else
                  {n: NAN for n in THETA_NAMES})
        b = self.best
        grid = self.margin_grid()
        margin = (grid["margin"] if grid else b.robust_margin if b is not None else NAN)
        crit = self.settings.objective == "critical_speed"
        use = self.usable_speed()
        out = jsonable({
            # what a user reads first: the speed the controller is usable to with its real
            # actuators, beside the open-loop critical speed it must exceed
            "usable_speed_m_s": use.get("usable_speed_m_s", NAN),
            "usable_speed_limited_by": use.get("usable_speed_limited_by"),
            "open_loop_critical_speed_m_s": self.open_loop_critical_speed_m_s,
            "linear_closed_loop_critical_speed_m_s": self.closed_loop_critical_speed_m_s,
            "linear_closed_loop_critical_speed_note": "ideal actuators (any flap angle and "
                                                      "rate)",
            "status": self.status,
            "controller_usable": self.controller is not None,
            "coefficients": coeffs,
            "flap_count": self.candidate.n_flaps if self.candidate else 0,
            "max_gain": b.max_gain if b is not None else NAN,
            "gain_limit": self.settings.gain_limit,
            "robust_margin": margin,
            "robust_margin_definition": "1 / max over the speed grid (0.5 m/s to speed_max_m_s, "
                                        "the worst speed refined) and a dense frequency grid "
                                        "of sigma_max(T(jw)), T the input complementary "
                                        "sensitivity of the flap loop (small-gain theorem), on "
                                        "the design model",
            "robust_margin_basis": "speed_grid" if grid else "robust_speeds",
            "robust_margin_worst_speed_m_s": grid["worst_speed_m_s"] if grid else NAN,
            # the margin the optimiser's cuts check (robust_speeds_m_s only)
            "robust_margin_at_robust_speeds": b.robust_margin if b is not None else NAN,
            "robust_T_inf_by_speed": b.t_inf_by_speed() if b is not None else {},
            "gamma_T_frobenius": b.gamma_T_frobenius if b is not None else NAN,
            # the optimiser's own margin 1/gamma_T against the verified one (peak tracking)
            "robust_margin_optimiser": (1.0 / b.gamma_T_frobenius
                                        if b is not None and b.gamma_T_frobenius > 0 else NAN),
            "closed_loop_stable_to_m_s": b.stable_to_m_s if b is not None else NAN,
            "design_modes": self.settings.n_modes,
            "verification": (b.verification.to_dict()
                             if b is not None and b.verification is not None else {}),
            "flap_positions_m": list(b.flap_positions_m) if b is not None else [],
            "buffeting": (self.extras["buffeting"].to_dict() if "buffeting" in self.extras
                          else {}),
            "zeta_min": self.settings.zeta_min,
            "active_constraints": self.extras.get("active_constraints", {}),
            "pareto": self.extras.get("pareto", {}),
            "fresh_variants": self.extras.get("fresh_variants", {}),
            "closed_loop_limits": self.extras.get("closed_loop_limits", {}),
            "acceptance": self.extras.get("acceptance", {"status": "not_run", "checks": []}),
            # the paper's Fig. 5 (right) as numbers (usable_speed.response_by_speed)
            "response_by_speed": self.extras.get("response_by_speed", []),
            "spectral_abscissa_by_speed": [
                {"speed_m_s": float(u), "abscissa_1_s": float(a)}
                for u, a in zip(self.abscissa_speeds_m_s, self.abscissa_1_s, strict=True)],
            "chosen_start": b.start if b is not None else None,
            "start_table": [s.table_row(b is not None and s.start == b.start)
                            for s in self.starts],
            "start_selection": "verified starts (damping, gain limit, verification model) "
                               "ranked by the NLP objective, lowest first, a phase-1 point "
                               "(no design objective) after them by margin "
                               "(bridgeflap.design.control.search.driver."
                               "select_start); each row is that start's own optimum",
            "dense_T_peak": 1.0 / margin if margin else NAN,
            "robust_bound_holds": b.robust_bound_holds if b is not None else None,
            "starts": [s.to_dict() for s in self.starts],
            "minimum_flaps": (self.min_flaps.to_dict() if self.min_flaps is not None
                              else {"minimum": None, "counts": [],
                                    **({"note": self.extras["minimum_flaps_note"]}
                                       if "minimum_flaps_note" in self.extras else {})}),
            "wall_time_s": self.wall_time_s,
            "settings": {k2: v for k2, v in asdict(self.settings).items() if k2 != "extras"
                         and (crit or k2 not in CRITICAL_SPEED_FIELDS)
                         and (k2 not in ACTUATOR_FIELDS or v != ACTUATOR_DEFAULTS[k2])
                         # shown when set (design.control.solve.pair_failure): older records stay as
                         # they were
                         and (k2 not in ("design_for_pair_failure", "layout_neighbours",
                                         "layout_adopt") or v)},
        })
        if "robust_margin_speed_grid" in self.extras:  # a design that reached its checks
            out["robust_margin_speed_grid"] = jsonable(self.extras["robust_margin_speed_grid"])
        if self.controller is None and b is not None:
            out["best_achievable"] = jsonable(self.best_achievable())
        # design.control.search.layout_search, only when it ran
        if "layout_neighbours" in self.extras:
            out["layout_neighbours"] = jsonable(self.extras["layout_neighbours"])
        # the critical-speed search (design.control.search.critical_speed), only when it ran
        if crit:
            out["critical_speed"] = jsonable(self.extras.get("critical_speed", {}))
        return out

    def margin_grid(self) -> dict:
        """The chosen design's margin check over the whole speed range
        (:func:`bridgeflap.design.control.review.checks.margin_on_speed_grid`), or ``{}`` when it
        did not run.

        Returns
        -------
        dict
            The grid (``speeds_m_s``, ``speed_count``), the smallest robust margin [-]
            (``margin``) and its speed ``worst_speed_m_s`` [m/s], the margin on the grid
            points only, at the design's speeds and on the verification model, and whether
            the reported margin holds; ``{}`` when the check did not run.
        """
        grid = self.extras.get("robust_margin_speed_grid") or {}
        return grid if isinstance(grid.get("margin"), float) else {}

    def best_achievable(self) -> dict:
        """The best design found when none is usable: its K, layout and
        closed-loop critical speed under the stated limits, and every check it misses. It is
        reported, never written as ``controller.toml``.

        Returns
        -------
        dict
            ``why_not_usable`` (one reason per missed check), the coefficients of ``K(s)``, the
            flap positions [m], the peak gain [rad/rad], ``stable_to_m_s`` and the closed- and
            open-loop critical speeds [m/s].
        """
        b, s = self.best, self.settings
        lim = self.extras.get("closed_loop_limits", {}) or {}
        why = []
        if b.max_gain > s.gain_limit:
            why.append(f"gain {b.max_gain:.4g} above the limit {s.gain_limit:g}")
        if not b.meets_damping:
            why.append(f"damping below zeta_min {s.zeta_min:g} on the design model "
                       f"(largest violation {b.max_violation_1_s:.3g} 1/s)")
        ver = b.verification
        if ver is not None and not ver.stable_everywhere:
            why.append(f"unstable on the {ver.modes}-mode verification model from "
                       f"{ver.stable_to_m_s:g} m/s (design range to {s.speed_max_m_s:g} m/s)")
        if not all(v.get("meets_damping", True) for v in b.variant_checks):
            why.append("a design variant misses zeta_min")
        if not b.actuator_ok and b.flap_demand:
            why.append("flap demand beyond the actuator limits: "
                       + "; ".join(b.flap_demand.get("exceeded", [])))
        acc = self.extras.get("acceptance") or {}
        if acc.get("status") in ("harm", "failed", "unresolved"):
            rob = acc.get("robustness") or {}
            why.append({"harm": f"acceptance harm: lowers the critical speed of "
                                f"{rob.get('harmed_count', '?')} of {rob.get('variants', '?')} "
                                "fresh bridge variants below their open-loop one",
                        "failed": "acceptance failed: " + acc.get(
                            "reason", "the independent closed loop disagrees"),
                        "unresolved": "acceptance unresolved: some fresh variant's crossing "
                                      "is not verified"}[acc["status"]])
        if not why:
            why.append(f"not verified (Ipopt: {b.ipopt_status})")
        k = self.candidate.compensator if self.candidate else None
        return {"status": "best_achievable_not_usable", "why_not_usable": why,
                "coefficients": ({n: getattr(k, n) for n in THETA_NAMES} if k else {}),
                "flap_positions_m": list(b.flap_positions_m), "max_gain": b.max_gain,
                "stable_to_m_s": b.stable_to_m_s,
                "closed_loop_critical_speed_m_s": lim.get("critical_speed_m_s", NAN),
                "critical_mechanism": lim.get("critical_mechanism"),
                "open_loop_critical_speed_m_s": min(
                    (v for v in (lim.get("open_loop_flutter_speed_m_s"),
                                 lim.get("open_loop_divergence_speed_m_s"))
                     if isinstance(v, float) and v == v), default=NAN)}

    def _rows(self) -> list[dict]:
        """The start table: one row per start (``time_s``, ``robust_margin`` [-], ...)."""
        b = self.best
        return [s.table_row(b is not None and s.start == b.start) for s in self.starts]

    def history(self) -> dict:
        """Ipopt iteration history of every start and round (``ipopt_history.json``):
        per round its label, status and the per-iteration ``obj``, ``inf_pr``, ``inf_du``,
        ``mu`` lists.

        Returns
        -------
        dict
            ``{"rounds": [...]}``, one dict per start and round.
        """
        out = []
        for s in self.starts:
            for r in s.rounds:
                out.append({"start": s.start, "round": r.round,
                            "placement": r.placement, "status": r.ipopt_status,
                            "iterations": r.iterations,
                            **{k: [x if np.isfinite(x) else None for x in v]
                               for k, v in (r.history or {}).items()}})
        return {"rounds": out}

    def compensator_response(self, frequency_hz=None):
        """Frequency response of the (candidate) compensator by :func:`scipy.signal.freqs`.

        Parameters
        ----------
        frequency_hz : array_like, optional
            [Hz]; default 600 points log-spaced over 1e-4 .. 20 Hz.

        Returns
        -------
        pandas.DataFrame
            ``frequency_hz``, ``omega_rad_s``, ``gain_rad_per_rad`` (``|K(j omega)|``),
            ``phase_deg`` and ``gain_limit_rad_per_rad``; empty without a candidate.
        """
        import pandas as pd
        import scipy.signal

        cols = ["frequency_hz", "omega_rad_s", "gain_rad_per_rad", "phase_deg",
                "gain_limit_rad_per_rad"]
        if self.candidate is None:
            return pd.DataFrame(columns=cols)
        f = (np.logspace(-4, np.log10(20.0), 600) if frequency_hz is None
             else np.asarray(frequency_hz, float))
        k = self.candidate.compensator
        # K(s) = (b2 s^2 + b1 s + b0) / (a2 s^2 + a1 s + 1) (model.aeroelastic.control)
        w, h = scipy.signal.freqs([k.b2, k.b1, k.b0], [k.a2, k.a1, 1.0], worN=2 * np.pi * f)
        return pd.DataFrame({"frequency_hz": f, "omega_rad_s": w, "gain_rad_per_rad": np.abs(h),
                             "phase_deg": np.degrees(np.angle(h)),
                             "gain_limit_rad_per_rad": self.settings.gain_limit})

    def _headline(self) -> dict:
        s = self.summary()
        return {"bridge": self.settings.bridge,
                **{k: s[k] for k in ("usable_speed_m_s", "usable_speed_limited_by",
                                     "open_loop_critical_speed_m_s")},
                "status": self.status,
                **{k: s[k] for k in ("controller_usable", "flap_count", "max_gain", "gain_limit",
                                     "robust_margin", "closed_loop_stable_to_m_s",
                                     "design_modes")},
                "starts": len(self.starts), "wall_time_s": self.wall_time_s}

    def plot(self, ax=None):
        """The margins per speed with the flap layout (:meth:`plot_margins`).

        Parameters
        ----------
        ax : sequence of four matplotlib.axes.Axes, optional
            Spectral-abscissa, damping-ratio and robust-margin axes, then the layout's (default:
            a new figure).

        Returns
        -------
        matplotlib.figure.Figure
            The figure drawn on (a new one when no axes are given).
        """
        return self.plot_margins(ax)

    def plot_bode(self, ax=None):
        """Gain and phase of the compensator against frequency [Hz] with the gain limit
        (:func:`bridgeflap.design.control.results.figures.bode`).

        Parameters
        ----------
        ax : sequence of two matplotlib.axes.Axes, optional
            Gain and phase axes (default: a new figure).

        Returns
        -------
        matplotlib.figure.Figure
            The figure drawn on (a new one when no axes are given).
        """
        from bridgeflap.design.control.results.figures import bode

        st = self.settings
        from bridgeflap.model.results import figure_of

        return figure_of(bode(self.candidate.compensator, st.gain_limit, ax,
                              (st.omega_min_rad_s, st.omega_max_rad_s),
                              title="designed compensator K(s)" if self.controller is not None
                              else f"candidate K(s) of a design that is {self.status} "
                                   "(not usable)"))

    def plot_margins(self, ax=None):
        """Spectral abscissa, smallest damping ratio of the movable branches with
        ``zeta_min``, robust margin per speed and the flap layout on the deck
        (:func:`bridgeflap.design.control.results.figures.margins`).

        Parameters
        ----------
        ax : sequence of four matplotlib.axes.Axes, optional
            Spectral-abscissa, damping-ratio and robust-margin axes, then the layout's (default:
            a new figure).

        Returns
        -------
        matplotlib.figure.Figure
            The figure drawn on (a new one when no axes are given).
        """
        from bridgeflap.design.control.results.figures import margins
        from bridgeflap.model.errors import BridgeflapError
        from bridgeflap.model.structure.loader import load_bridge

        try:
            spec = load_bridge(self.settings.bridge)
        except BridgeflapError:  # the layout is then drawn without towers
            spec = None
        from bridgeflap.model.results import figure_of

        return figure_of(margins(self, ax, spec))

    # ---- headline numbers (the same as in summary(); NaN when not computed)
    @property
    def closed_loop_critical_speed_m_s(self) -> float:
        """Closed-loop critical speed [m/s] on the verification model (flutter or divergence,
        whichever comes first; ``closed_loop_limits``)."""
        v = (self.extras.get("closed_loop_limits") or {}).get("critical_speed_m_s")
        return float(v) if isinstance(v, int | float) else NAN

    @property
    def closed_loop_critical_mechanism(self) -> str | None:
        """``flutter`` or ``divergence`` (None when not computed)."""
        return (self.extras.get("closed_loop_limits") or {}).get("critical_mechanism")

    @property
    def open_loop_critical_speed_m_s(self) -> float:
        """Open-loop critical speed [m/s] on the verification model."""
        lim = self.extras.get("closed_loop_limits") or {}
        vals = [v for v in (lim.get("open_loop_flutter_speed_m_s"),
                            lim.get("open_loop_divergence_speed_m_s"))
                if isinstance(v, int | float) and v == v]
        return float(min(vals)) if vals else NAN

    def usable_speed(self) -> dict:
        """The usable-speed check's block (``acceptance.usable_speed``; ``{}`` when it did not
        run): :mod:`bridgeflap.design.assessment.usable_speed`.

        Returns
        -------
        dict
            ``status``, ``usable_speed_m_s`` [m/s] and what limits it
            (``usable_speed_limited_by``), the linear closed-loop and open-loop critical
            speeds [m/s], the 3-sigma flap angle and rate speeds [m/s], the saturated loop's
            bracket [m/s] and the limits used; ``{}`` when the check did not run.
        """
        u = (self.extras.get("acceptance") or {}).get("usable_speed") or {}
        return u if "usable_speed_m_s" in u else {}

    @property
    def usable_speed_m_s(self) -> float:
        """The speed [m/s] up to which the controller does what its linear design promises
        with its real actuators in the design turbulence: the lowest of the linear closed-loop
        critical speed, the 3 sigma flap angle and rate limits and the saturated loop's holding
        speed (NaN when the usable-speed check did not run)."""
        v = self.usable_speed().get("usable_speed_m_s")
        return float(v) if isinstance(v, int | float) else NAN

    @property
    def usable_speed_limited_by(self) -> str | None:
        """Which limit binds the usable speed (``linear critical speed``, ``flap angle 3
        sigma``, ``flap rate 3 sigma`` or ``saturated loop``; None when not computed)."""
        return self.usable_speed().get("usable_speed_limited_by")

    @property
    def acceptance_status(self) -> str:
        """The acceptance verdict (``passed``, ``harm``, ``failed``, ``unresolved``,
        ``not_run``)."""
        return (self.extras.get("acceptance") or {}).get("status", "not_run")
