"""The record of the flap placement search: one row per layout tried
(:class:`PlacementRow`) and the search's result with its trade-off, table and figure
(:class:`PlacementResult`); :mod:`bridgeflap.design.control.search.placement` fills them in.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from bridgeflap.model.results import ResultData, strict_json

__all__ = ["PlacementResult", "PlacementRow"]

NAN = float("nan")


def _finite(v) -> bool:
    return isinstance(v, (int, float)) and math.isfinite(v)


def _f(v, spec) -> str:
    return format(v, spec) if _finite(v) else "-"


@dataclass(frozen=True)
class PlacementRow:
    """One layout the search tried, with its re-optimised K(s) and what it meets.

    ``groups``: the mirror groups of the layout (innermost 0); ``removed_group`` the group the
    step removed from its parent (None: the full layout); ``meets`` whether it meets the target,
    ``why_not`` one reason per missed criterion (empty when it meets it).
    """

    step: int
    groups: tuple
    removed_group: int | None
    removed_radius_m: float
    flap_positions_m: tuple
    status: str
    verified: bool
    meets: bool
    why_not: tuple
    theta: tuple | None
    max_gain: float
    robust_margin: float
    stable_to_m_s: float
    flap_angle_3sigma_at_target_deg: float
    flap_rate_3sigma_at_target_deg_s: float
    demand_within_limits: bool
    no_harm_on_scenarios: bool
    failed_strip_stable_to_m_s: float
    failed_strip_worst_position_m: float
    iterations: int
    time_s: float

    @property
    def strips(self) -> int:
        """Flap strips (LE+TE pairs) of the layout."""
        return len(self.flap_positions_m)

    @strict_json
    def to_dict(self) -> dict:
        """One entry of ``rows`` in the JSON."""
        return {"step": self.step, "strips": self.strips, "groups": list(self.groups),
                "removed_group": self.removed_group, "removed_radius_m": self.removed_radius_m,
                "flap_positions_m": list(self.flap_positions_m), "status": self.status,
                "verified": self.verified, "meets_target": self.meets,
                "why_not": list(self.why_not),
                "theta": list(self.theta) if self.theta is not None else None,
                "max_gain": self.max_gain, "robust_margin": self.robust_margin,
                "stable_to_m_s": self.stable_to_m_s,
                "flap_angle_3sigma_at_target_deg": self.flap_angle_3sigma_at_target_deg,
                "flap_rate_3sigma_at_target_deg_s": self.flap_rate_3sigma_at_target_deg_s,
                "demand_within_limits": self.demand_within_limits,
                "no_harm_on_scenarios": self.no_harm_on_scenarios,
                "failed_strip_stable_to_m_s": self.failed_strip_stable_to_m_s,
                "failed_strip_worst_position_m": self.failed_strip_worst_position_m,
                "iterations": self.iterations, "time_s": self.time_s}


@dataclass(frozen=True)
class PlacementResult(ResultData):
    """The placement search (:func:`placement_search`).

    Attributes
    ----------
    status : str
        ``found`` (the chosen layout meets the target and no one-group removal of it does),
        ``no_layout_meets_target`` (not even every candidate strip meets it: ``rows[0]``, the
        full layout, is the best achievable, with its reasons) or ``stopped`` (``max_steps``
        ended the search before a removal failed).
    target_m_s : float
        The target speed [m/s]; ``target_basis`` says where it comes from.
    open_loop : dict
        The open loop's flutter, divergence and critical speeds [m/s] (verification model).
    rows : tuple of PlacementRow
        Every layout tried, in order.
    path : tuple of int
        Indices into ``rows`` of the layouts kept step by step, from the full one.
    chosen : int or None
        Index into ``rows`` of the chosen layout (None when none meets the target).
    candidates_m : tuple of float
        The candidate strip centres [m].
    groups : int
        Mirror groups of the candidates.
    time_s : float
        Wall time [s].
    """

    status: str
    target_m_s: float
    target_basis: str
    open_loop: dict
    rows: tuple
    path: tuple
    chosen: int | None
    candidates_m: tuple
    groups: int
    time_s: float
    settings_summary: dict = field(default_factory=dict)

    _HEADLINE_KEYS = ("status", "target_m_s", "chosen_strips", "layouts_tried")

    @property
    def chosen_row(self) -> PlacementRow | None:
        """The chosen layout's row (None when no layout meets the target)."""
        return None if self.chosen is None else self.rows[self.chosen]

    def tradeoff(self) -> list[dict]:
        """The trade-off, one entry per strip count.

        Returns
        -------
        list of dict
            The layouts kept on the path (``kind`` "kept", each meets the target), then the
            best layout of the next smaller count (``kind`` "best of the next count (fails)",
            the one that failed by the least: verified first, then the higher stable speed,
            then the smaller flap angle), each with its strips, positions [m], stable speed
            [m/s], max gain, 3 sigma flap angle [deg] and rate [deg/s] at the target, the
            failed-strip stable speed [m/s], robust margin and reasons.
        """
        out = []
        for k in self.path:
            out.append({"strips": self.rows[k].strips, "kind": "kept", "row": k})
        if self.chosen is not None:
            below = [k for k, r in enumerate(self.rows)
                     if r.step == self.rows[self.chosen].step + 1]
            if below:
                k = min(below, key=lambda k: (not self.rows[k].verified,
                                              -np.nan_to_num(self.rows[k].stable_to_m_s),
                                              np.nan_to_num(
                                                  self.rows[k].flap_angle_3sigma_at_target_deg,
                                                  nan=1e9)))
                out.append({"strips": self.rows[k].strips, "kind": "best of the next count "
                                                                   "(fails)", "row": k})
        for o in out:
            r = self.rows[o["row"]]
            o.update({"flap_positions_m": list(r.flap_positions_m), "meets_target": r.meets,
                      "stable_to_m_s": r.stable_to_m_s, "max_gain": r.max_gain,
                      "flap_angle_3sigma_at_target_deg": r.flap_angle_3sigma_at_target_deg,
                      "flap_rate_3sigma_at_target_deg_s": r.flap_rate_3sigma_at_target_deg_s,
                      "failed_strip_stable_to_m_s": r.failed_strip_stable_to_m_s,
                      "robust_margin": r.robust_margin, "ipopt_status": r.status,
                      "why_not": list(r.why_not)})
        return out

    @strict_json
    def summary(self) -> dict:
        """The JSON of ``bridgeflap placement``.

        Returns
        -------
        dict
            Status, target and open-loop speeds [m/s], the chosen layout and K, the method and
            criterion in words, the settings each layout was designed with, the trade-off
            (:meth:`tradeoff`) and every row.
        """
        c = self.chosen_row
        return {"status": self.status, "target_m_s": self.target_m_s,
                "target_basis": self.target_basis, **self.open_loop,
                "chosen_strips": c.strips if c is not None else None,
                "chosen_flap_positions_m": list(c.flap_positions_m) if c is not None else None,
                "chosen_theta": list(c.theta) if c is not None and c.theta else None,
                "candidate_strips": len(self.candidates_m), "mirror_groups": self.groups,
                "layouts_tried": len(self.rows), "time_s": self.time_s,
                "method": "greedy backward elimination over mirror groups from every "
                          "candidate strip; K(s) re-optimised per layout (warm-started from "
                          "the layout it came from); a step keeps the layout that meets the "
                          "target with the fewest strips, then the largest robust margin; it "
                          "stops when no one-group removal meets the target",
                "criterion": "verified fixed-layout design (damping to the target on the "
                             "design model, stable on the verification model, gain limit, "
                             "no harm on the scenario bridges), 3 sigma flap angle and rate "
                             "within the actuator limits at the target (linear, design "
                             "turbulence), and every one-strip-failed loop stable to the "
                             "open-loop critical speed",
                "settings": self.settings_summary,
                "tradeoff": self.tradeoff(),
                "rows": [r.to_dict() for r in self.rows]}

    def table(self) -> str:
        """The trade-off as plain text.

        Returns
        -------
        str
            One line per strip count of :meth:`tradeoff`, the reasons of a failing one beside
            it.
        """
        head = (f"{'strips':>6} {'meets':>5} {'stable to':>9} {'max gain':>8} "
                f"{'angle 3s':>8} {'rate 3s':>8} {'1 failed':>8}  {'Ipopt':<28} layout |x| [m]")
        lines = [head]
        for t in self.tradeoff():
            ax = sorted({round(abs(x), 1) for x in t["flap_positions_m"]})
            lines.append(f"{t['strips']:>6} {str(t['meets_target']):>5} "
                         f"{_f(t['stable_to_m_s'], '.2f'):>9} {_f(t['max_gain'], '.2f'):>8} "
                         f"{_f(t['flap_angle_3sigma_at_target_deg'], '.1f'):>8} "
                         f"{_f(t['flap_rate_3sigma_at_target_deg_s'], '.1f'):>8} "
                         f"{_f(t['failed_strip_stable_to_m_s'], '.1f'):>8}  "
                         f"{t['ipopt_status']:<28} {', '.join(f'{a:g}' for a in ax)}"
                         + ("" if t["meets_target"] else f"  ({'; '.join(t['why_not'][:2])})"))
        return "\n".join(lines)

    def plot(self, ax=None):
        """Strips against the 3 sigma flap angle at the target and against the max gain.

        Parameters
        ----------
        ax : sequence of two matplotlib Axes, optional
            Where to draw (default: a new figure).

        Returns
        -------
        numpy.ndarray of matplotlib.axes.Axes
            Every layout tried (crosses: fails the target; circles: meets it), the
            elimination path (line), the chosen layout (star) and the limits (dashed).
        """
        import matplotlib.pyplot as plt

        if ax is None:
            fig, ax = plt.subplots(1, 2, figsize=(10, 4))
        ax = np.atleast_1d(ax)
        lim = self.settings_summary.get("flap_angle_limit_deg", NAN)
        glim = self.settings_summary.get("gain_limit", NAN)
        for a, key, label, limit in ((ax[0], "flap_angle_3sigma_at_target_deg",
                                      f"3$\\sigma$ flap angle at {self.target_m_s:.1f} m/s "
                                      "[deg]", lim),
                                     (ax[-1], "max_gain", "max |K(j$\\omega$)| [rad/rad]", glim)):
            xs = [r.strips for r in self.rows]
            ys = [getattr(r, key) for r in self.rows]
            ok = [r.meets for r in self.rows]
            a.scatter([x for x, o in zip(xs, ok, strict=True) if not o],
                      [y for y, o in zip(ys, ok, strict=True) if not o], marker="x",
                      color="0.6", label="fails the target")
            a.scatter([x for x, o in zip(xs, ok, strict=True) if o],
                      [y for y, o in zip(ys, ok, strict=True) if o], marker="o",
                      facecolors="none", edgecolors="C0", label="meets the target")
            a.plot([self.rows[k].strips for k in self.path],
                   [getattr(self.rows[k], key) for k in self.path], "-", color="C0",
                   label="elimination path")
            if self.chosen is not None:
                a.plot([self.rows[self.chosen].strips], [getattr(self.rows[self.chosen], key)],
                       "*", color="C3", markersize=14, label="chosen")
            if _finite(limit):
                a.axhline(limit, color="k", ls="--", lw=1, label="limit")
            a.set_xlabel("flap strips (LE+TE pairs)")
            a.set_ylabel(label)
            a.grid(True, alpha=0.3)
        ax[0].legend(fontsize=8)
        ax[0].set_title(f"placement: target {self.target_m_s:.2f} m/s, {self.status}")
        return ax

