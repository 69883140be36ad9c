"""The record of a stability sweep: :class:`StabilitySweep` (branches, crossings, summary).

Produced by :func:`bridgeflap.model.stability.sweeps.sweep` (dense) and
:func:`bridgeflap.model.stability.hopf.fast_sweep` (fast), so it sits below both; re-exported by
:mod:`bridgeflap.model.stability.sweeps`, its public home. Its ``plot`` methods call
:mod:`bridgeflap.model.stability.plots` lazily.

May import: the foundation, :mod:`bridgeflap.model.stability.tracking` (statuses, :class:`Crossing`)
and
:mod:`bridgeflap.model.stability.plots` (lazily); nothing else of bridgeflap.model.stability,
nothing above it.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from bridgeflap.model.results import ResultData, sweep_dataset, sweep_frame
from bridgeflap.model.stability.tracking import (
    BRACKET_FAILED,
    CONVERGED,
    NOT_EVALUATED,
    UNSTABLE_AT_FIRST,
    UNVERIFIED,
    Crossing,
    static_status,
)

__all__ = ["StabilitySweep"]


@dataclass(frozen=True)
class StabilitySweep(ResultData):
    """Result of :func:`bridgeflap.model.stability.sweeps.sweep`.

    Attributes
    ----------
    speeds : ndarray (n_u,)
        [m/s].
    eigenvalues : ndarray (n_u, n_x)
        All eigenvalues [1/s] at each speed.
    branches : ndarray (n_b, n_u)
        Tracked structural branches [1/s].
    branch_labels : tuple of str
        Structural mode of each branch at U = 0.
    flutter, divergence : Crossing
    divergence_static_speed : float
        Root [m/s] of the static condition, wherever it lies (NaN when none): the summary
        reports it only inside the grid
        (:func:`~bridgeflap.model.stability.tracking.static_status`).
    critical_participation : dict
        Share of each structural coordinate in the flutter eigenvector (kinetic energy).
    divergence_participation : dict
        Share of each structural coordinate in the eigenvector of the real root that crosses
        at the refined divergence crossing (strain energy ``K_jj |q_j|^2``: a static mode has
        no kinetic energy; ``{}`` when it did not converge). The summary's
        ``critical_participation`` is the governing crossing's
        (:meth:`bridgeflap.model.analysis.FlutterResult.summary`).
    second_flutter : Crossing
        The next tracked oscillatory branch to cross after the critical one.
    tracking_substeps, tracking_forced_steps : int
        Extra eigenvalue evaluations spent on tracking sub-steps, and steps still ambiguous
        at the smallest sub-step or with the budget spent.
    method : str
        The sweep that produced the numbers, ``"dense"`` or ``"fast"``
        (:func:`bridgeflap.model.stability.sweeps.sweep`).
    eigen_solutions : int
        Dense eigenvalue problems of ``A(U)`` solved (a fast sweep that fell back to dense
        counts both).
    fallback_reason : str
        Why a fast sweep fell back to the dense one ("" otherwise).
    """

    speeds: np.ndarray
    eigenvalues: np.ndarray
    branches: np.ndarray
    branch_labels: tuple
    flutter: Crossing
    divergence: Crossing
    divergence_static_speed: float
    critical_branch: str
    critical_participation: dict = field(default_factory=dict)
    divergence_participation: dict = field(default_factory=dict)
    second_flutter: Crossing = field(
        default_factory=lambda: Crossing(float("nan"), float("nan"), NOT_EVALUATED))
    tracking_substeps: int = 0
    tracking_forced_steps: int = 0
    method: str = "dense"
    eigen_solutions: int = 0
    fallback_reason: str = ""

    _HEADLINE_KEYS = ("flutter_speed_m_s", "flutter_frequency_hz", "flutter_status",
                      "divergence_speed_m_s", "divergence_status", "critical_branch_label",
                      "speed_min_m_s", "speed_max_m_s", "sweep_method", "eigen_solutions")

    @property
    def divergence_static_status(self) -> str:
        """:func:`~bridgeflap.model.stability.tracking.static_status` of the static divergence root
        on this grid."""
        return static_status(self.divergence_static_speed, self.speeds)

    def damping_ratios(self) -> np.ndarray:
        """Branch damping ratios ``-Re/|lambda|`` (n_b, n_u).

        Returns
        -------
        numpy.ndarray
            Damping ratio [-] of each branch (rows) at each speed (columns); NaN where a
            branch has no eigenvalue.
        """
        lam = self.branches
        with np.errstate(invalid="ignore", divide="ignore"):
            return -lam.real / np.abs(lam)

    def frequencies_hz(self) -> np.ndarray:
        """Branch frequencies ``|Im|/2pi`` [Hz] (n_b, n_u).

        Returns
        -------
        numpy.ndarray
            Frequency [Hz] of each branch (rows) at each speed (columns).
        """
        return np.abs(self.branches.imag) / (2 * np.pi)

    def summary(self) -> dict:
        """JSON-ready numbers of the flutter/divergence contract.

        Besides speeds and statuses: ``flutter_re_lambda_slope_per_m`` (``d Re lambda/dU``
        [1/m]), ``flutter_damping_slope_s_per_m`` (``d zeta/dU`` [s/m]) and ``flutter_onset``
        (hard/soft) at the crossing; the second-critical branch (``second_critical_branch_label``,
        ``second_flutter_speed_m_s`` and its status); ``divergence_static_status`` with the
        static speed NaN unless inside the grid; ``<kind>_bracket_m_s`` and ``<kind>_reason``
        for a crossing seen but not converged.

        Returns
        -------
        dict
            Plain Python numbers and strings (units in the key names; NaN where a quantity was
            not found on the grid).
        """
        part = sorted(self.critical_participation.items(), key=lambda kv: -kv[1])[:4]
        extra = {}
        for k, c in (("flutter", self.flutter), ("divergence", self.divergence)):
            if c.status == UNSTABLE_AT_FIRST:
                extra[f"{k}_unstable_from_m_s"] = c.bracket[0]
            elif c.status in (BRACKET_FAILED, UNVERIFIED):
                extra[f"{k}_bracket_m_s"] = [float(c.bracket[0]), float(c.bracket[1])]
                extra[f"{k}_reason"] = c.reason
        static_st = self.divergence_static_status
        sec = self.second_flutter
        return {
            **extra,
            "flutter_speed_m_s": self.flutter.speed,
            "flutter_frequency_hz": self.flutter.frequency_hz,
            "flutter_status": self.flutter.status,
            "flutter_re_lambda_slope_per_m": (self.flutter.re_slope_per_m
                                              if self.flutter.status == CONVERGED
                                              else float("nan")),
            "flutter_damping_slope_s_per_m": self.flutter.damping_slope_s_per_m(),
            "flutter_onset": self.flutter.onset(),
            "divergence_speed_m_s": self.divergence.speed,
            "divergence_status": self.divergence.status,
            "divergence_re_lambda_slope_per_m": (self.divergence.re_slope_per_m
                                                 if self.divergence.status == CONVERGED
                                                 else float("nan")),
            "divergence_branch_label": self.divergence.label,
            "divergence_branch_label_source": self.divergence.label_source,
            "divergence_mechanism": self.divergence.mechanism,
            "divergence_static_speed_m_s": (self.divergence_static_speed
                                            if static_st == CONVERGED else float("nan")),
            "divergence_static_status": static_st,
            "critical_branch_label": self.critical_branch,
            "critical_branch_label_source": self.flutter.label_source,
            "critical_participation": dict(part),
            "second_critical_branch_label": sec.label,
            "second_flutter_speed_m_s": sec.speed,
            "second_flutter_frequency_hz": sec.frequency_hz,
            "second_flutter_status": sec.status,
            "speed_min_m_s": float(self.speeds[0]),
            "speed_max_m_s": float(self.speeds[-1]),
            "sweep_method": self.method,
            "sweep_fallback_reason": self.fallback_reason,
            "eigen_solutions": int(self.eigen_solutions),
        }

    def to_dataframe(self):
        """One row per speed x branch (:func:`bridgeflap.model.results.sweep_frame`).

        Returns
        -------
        pandas.DataFrame
            Columns ``speed_m_s``, ``branch``, ``frequency_hz``, ``damping_ratio``,
            ``real_part_1_s``, ``imag_part_1_s``.
        """
        return sweep_frame(self)

    def to_xarray(self, attrs=None):
        """The branches on ``(branch, speed_m_s)``
        (:func:`bridgeflap.model.results.sweep_dataset`).

        Parameters
        ----------
        attrs : mapping, optional
            Extra dataset attributes (e.g. the bridge name), added to the flutter and divergence
            numbers.

        Returns
        -------
        xarray.Dataset
            ``frequency_hz``, ``damping_ratio``, ``real_part_1_s``, ``imag_part_1_s`` on
            ``(branch, speed_m_s)``, each with its ``units`` attribute.
        """
        return sweep_dataset(self, attrs)

    def plot_root_locus(self, ax=None, title: str = "root locus", reference=None):
        """Tracked branches in the complex plane (both axes 1/s, coloured by wind speed);
        ``reference``: another sweep drawn in grey
        (:func:`bridgeflap.model.stability.plots.root_locus`).

        Parameters
        ----------
        ax : matplotlib.axes.Axes, optional
            Axes to draw on (default: a new figure).
        title : str, default "root locus"
            Axes title.
        reference : StabilitySweep, optional
            Another sweep (e.g. the open loop) drawn underneath in grey.

        Returns
        -------
        matplotlib.axes.Axes
            The axes drawn on.
        """
        from bridgeflap.model.stability.plots import root_locus

        return root_locus(self, ax, title=title, reference=reference)

    def plot(self, axes=None, title: str = "", reference=None):
        """Root locus (left), V-g and V-f (right), unclipped
        (:func:`bridgeflap.model.stability.plots.stability_panels`).

        Parameters
        ----------
        axes : sequence of three matplotlib.axes.Axes, optional
            Root-locus, V-g and V-f axes (default: a new figure).
        title : str, default ""
            Figure title, before the flutter and divergence speeds.
        reference : StabilitySweep, optional
            Another sweep (e.g. the open loop) drawn underneath in grey.

        Returns
        -------
        matplotlib.figure.Figure
            The figure drawn on (a new one when no axes are given).
        """
        from bridgeflap.model.stability.plots import stability_panels

        return stability_panels(self, axes, title=title, reference=reference)
