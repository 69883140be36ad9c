"""Settings of the compensator design problem: :class:`DesignSettings` and its TOML file.

Defaults are the Humber design of seed §6; ``runs/humber_flaps.toml`` documents every key.
Every TOML key is a field of :class:`DesignSettings` (``[tables]`` only group them).
"""

from __future__ import annotations

import math
import os
import sys
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from bridgeflap.design.io.api_args import check_load_settings_args, check_settings
from bridgeflap.model.aeroelastic.actuator_limits import (
    ACTUATOR_DEFAULTS,
    ACTUATOR_FIELDS,
    check_actuator_value,
)
from bridgeflap.model.errors import BridgeflapInputError

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

#: Names of the compensator coefficients theta, ``K(s) = (b2 s^2 + b1 s + b0) / (a2 s^2 + a1 s
#: + 1)`` (:class:`model.aeroelastic.control.Compensator`).
THETA_NAMES = ("b2", "b1", "b0", "a2", "a1")
#: Design objectives (``DesignSettings.objective``): the robust margin subject to stability up
#: to the design speed, or the closed-loop critical speed subject to a robust margin.
OBJECTIVES = ("margin", "critical_speed")
#: Rules of the design variants (``DesignSettings.variant_rule``): ``"no_harm"``, each variant's
#: closed loop damped (``zeta_min``) at every speed below its own open-loop critical speed (up
#: to the do-no-harm check's grid end, 1.5 ``speed_max_m_s``); ``"stable"``, damped 0 ..
#: ``speed_max_m_s`` like the nominal bridge.
VARIANT_RULES = ("no_harm", "stable")
#: Settings of the critical-speed search only (left out of a margin design's JSON summary).
CRITICAL_SPEED_FIELDS = ("objective", "margin_min", "critical_speed_step_m_s",
                         "critical_speed_tol_m_s", "critical_speed_max_m_s",
                         "critical_speed_evaluations")


#: Upper bounds of the card's counts (a card is refused before any work beyond them): modes as
#: bridgeflap.model.arguments.MAX_MODES (a 100-mode eigenproblem, ~600 states, takes 0.1 s per
#: speed); scenario variants cost a model and lazy constraints each (12 take the default design
#: ~2 minutes); fresh variants ~1 s each; Ipopt iterations and starts beyond these are days.
_UPPER = {"n_modes": 100, "verification_modes": 100, "fresh_variant_modes": 100,
          "flap_count": 200, "starts": 64, "max_iter": 100_000, "resolve_max_iter": 100_000,
          "n_eig": 50, "n_omega": 10_000, "n_robust_omega": 10_000, "pareto_step": 200,
          "variants": 256, "fresh_variants": 4096}


def _num(field_name, v, positive=False, nonneg=False):
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise BridgeflapInputError(field_name, f"must be a number, got {v!r}")
    v = float(v)
    if not math.isfinite(v):
        raise BridgeflapInputError(field_name, f"must be finite, got {v!r}")
    if positive and v <= 0:
        raise BridgeflapInputError(field_name, f"must be > 0, got {v!r}")
    if nonneg and v < 0:
        raise BridgeflapInputError(field_name, f"must be >= 0, got {v!r}")
    return v


@dataclass(frozen=True)
class DesignSettings:
    """Definition of the design problem (defaults: Humber, the paper, §6; overridable by TOML).

    Units: lengths [m], speeds [m/s], rates [1/s], frequencies [rad/s], gains [rad/rad].

    ``zeta_min`` [-] is the minimum damping ratio ``-Re lambda / |lambda|`` demanded of every
    closed-loop branch the flaps can move (default 0.5 %, half the structural 1 %), at every
    design speed 0..``speed_max_m_s``; the copies of the aerodynamic lag poles ``-p_i U / b``
    and of the compensator poles are excluded (:mod:`bridgeflap.design.control.formulation.eigen`).

    ``robust_cut_tol`` [-]: the cutting planes stop when the dense peak of ``sigma_max(T)`` is
    within this of the optimiser's bound ``gamma_T`` (``robust_bound_holds``), i.e. the
    verified margin is within it of the optimiser's (default 1 %,
    :data:`bridgeflap.design.control.formulation.nlp_tolerances.ROBUST_CUT_TOL`).

    ``objective``: ``"margin"`` (default) maximises the robust margin subject to the damping up
    to ``speed_max_m_s``; ``"critical_speed"`` searches the largest design speed whose
    max-margin design verifies with robust margin >= ``margin_min`` [-], from
    ``speed_max_m_s`` in steps of ``critical_speed_step_m_s`` up to ``critical_speed_max_m_s``
    (0: ``2 speed_max_m_s``, the closed-loop limits' range), bisected to
    ``critical_speed_tol_m_s``, at most ``critical_speed_evaluations`` inner designs
    (:mod:`bridgeflap.design.control.search.critical_speed`).

    ``layout_neighbours``: after the design, the chosen layout is compared with its
    neighbouring integer layouts (one mirror pair added or removed, centred blocks) at
    re-optimised K (:mod:`bridgeflap.design.control.search.layout_search`; JSON key
    ``layout_neighbours``); ``layout_adopt``: the best verified neighbour replaces it when its
    margin is larger. Both left out of the design's JSON settings while false.

    ``flap_angle_limit_deg`` [deg] and ``flap_rate_limit_deg_s`` [deg/s]: the flap actuator's
    angle and rate limits (defaults 20 deg and 40 deg/s, engineering estimates for hydraulic
    flap actuators, :mod:`bridgeflap.model.aeroelastic.actuator_limits`); ``bridgeflap actuators
    --card`` simulates the designed loop with them in turbulent wind.
    ``actuator_design_speeds_m_s`` [m/s]: at these speeds the NLP holds the 3 sigma flap angle
    and rate of the linear closed loop in the bridge's design turbulence within those limits
    (:mod:`bridgeflap.design.control.formulation.actuator_demand`; empty: not constrained).
    Left out of the design's JSON settings while at their defaults.

    Attributes
    ----------
    bridge : str
        The bridge designed for: a name, a bridge file or ``file.toml:variant`` (default
        ``"humber"``).
    n_modes, verification_modes : int
        Retained vertical + torsional modes of the design model and of the dense verification
        (default 16, 16).
    flap_count : int
        Candidate flap pairs side by side over the main span (default 25).
    flap_positions_m : tuple of float
        The fitted flap strips' centres from mid-span [m]; empty: all ``flap_count`` candidates.
    flap_width_m, flap_chord_m : float
        Spanwise width of a strip [m] (default 56.4) and chordwise flap size [m] (default 3).
    speed_max_m_s, design_step_m_s, check_step_m_s : float
        Highest design speed [m/s] (default 85), the design grid's step (5) and the
        verification grid's step (0.25).
    zeta_min : float
        Minimum damping ratio [-] of every branch the flaps move (default 0.005).
    gain_limit : float
        Bound on ``sup |K(jw)|`` [rad/rad] (default 15).
    weight_robust, weight_buffeting, weight_regularisation : float
        Objective weights [-] (defaults 1, 0, 1e-3).
    starts, seed : int
        Optimiser starts (default 2) and their random seed (1).
    variants : int
        Scenario bridges of the stated uncertainty designed for at once (default 0: the nominal
        bridge only).
    compensator_damping_min : float
        Minimum damping ratio [-] of the compensator's own poles (default 0).
    objective : {"margin", "critical_speed"}
        What the design maximises (default ``"margin"``).
    flap_angle_limit_deg, flap_rate_limit_deg_s : float
        Actuator limits [deg], [deg/s] for the actuator check (defaults 20, 40).

    The packaged card, ``design/studies/humber_flaps.toml``, documents every key
    (docs/reference/formats/card.md).

    Examples
    --------
    >>> from bridgeflap import design
    >>> design.DesignSettings(n_modes=8).n_modes
    8
    """

    bridge: str = "humber"
    n_modes: int = 16
    verification_modes: int = 16
    flap_count: int = 25
    flap_positions_m: tuple = ()
    flap_width_m: float = 56.4          # spanwise length of each flap pair: 1410 m / 25
    flap_chord_m: float = 3.0           # chordwise, inside the 22 m deck chord (seed §6)
    leading_edge: bool = True
    trailing_edge: bool = True
    speed_max_m_s: float = 85.0
    design_step_m_s: float = 5.0
    check_step_m_s: float = 0.25
    zeta_min: float = 0.005
    n_eig: int = 3
    gain_limit: float = 15.0
    omega_min_rad_s: float = 1e-3
    omega_max_rad_s: float = 1e2
    n_omega: int = 120
    robust_design_speeds_m_s: tuple = (20.0, 40.0, 60.0, 70.0, 80.0, 85.0)
    robust_omega_min_rad_s: float = 0.02
    robust_omega_max_rad_s: float = 10.0
    n_robust_omega: int = 20
    robust_speeds_m_s: tuple = (10.0, 20.0, 30.0, 40.0, 50.0, 60.0, 70.0, 80.0, 85.0)
    robust_cut_tol: float = 0.01
    weight_robust: float = 1.0
    weight_regularisation: float = 1e-3
    weight_buffeting: float = 0.0
    buffeting_speeds_m_s: tuple = (10.0, 20.0, 25.0)
    buffeting_term: str = "modal"
    optimise_placement: bool = False
    weight_flaps: float = 0.0
    symmetric_layout: bool = True
    flap_budget: int = 0
    starts: int = 2
    seed: int = 1
    parallel: bool = False
    max_iter: int = 80
    resolve_max_iter: int = 60
    cutting_plane_rounds: int = 5
    placement_cut_rounds: int = -1
    b_bound: float = 15.0
    a2_bounds: tuple = (1e-3, 5.0)
    a1_bounds: tuple = (1e-2, 10.0)
    min_flap_counts: tuple = ()
    pareto: bool = False
    variants: int = 0
    fresh_variants: int = 0
    fresh_variant_modes: int = 30
    variant_seed: int = 7
    variant_fixed: tuple = ("deck.half_chord_m", "aero.coherence_decay")
    variant_speeds: str = "lazy"
    variant_rule: str = "stable"
    variant_corners: tuple = ()
    compensator_damping_min: float = 0.0
    layout_dead_band: float = 0.05
    design_for_pair_failure: bool = False
    pareto_step: int = 2
    objective: str = "margin"
    margin_min: float = 0.25
    critical_speed_step_m_s: float = 10.0
    critical_speed_tol_m_s: float = 1.0
    critical_speed_max_m_s: float = 0.0
    critical_speed_evaluations: int = 10
    layout_neighbours: bool = False
    layout_adopt: bool = False
    flap_angle_limit_deg: float = ACTUATOR_DEFAULTS["flap_angle_limit_deg"]
    flap_rate_limit_deg_s: float = ACTUATOR_DEFAULTS["flap_rate_limit_deg_s"]
    actuator_design_speeds_m_s: tuple = ()
    extras: dict = field(default_factory=dict, compare=False)

    def __post_init__(self):
        """Validate (one field named per error)."""
        _num("gain_limit", self.gain_limit, positive=True)
        for name in ACTUATOR_FIELDS:  # actuator limits (engineering estimates: actuator_limits)
            check_actuator_value(name, getattr(self, name))
        for name in ("flap_width_m", "flap_chord_m", "speed_max_m_s", "design_step_m_s",
                     "check_step_m_s", "omega_min_rad_s", "omega_max_rad_s",
                     "robust_omega_min_rad_s", "robust_omega_max_rad_s"):
            _num(name, getattr(self, name), positive=True)
        _num("zeta_min", self.zeta_min, nonneg=True)
        if self.zeta_min >= 1.0:
            raise BridgeflapInputError("zeta_min", f"must be < 1, got {self.zeta_min!r}")
        for name in ("weight_regularisation",
                     "weight_buffeting", "weight_robust", "weight_flaps"):
            _num(name, getattr(self, name), nonneg=True)
        for name in ("n_modes", "verification_modes", "flap_count", "n_eig", "n_omega",
                     "n_robust_omega", "starts", "max_iter", "resolve_max_iter",
                     "pareto_step", "fresh_variant_modes"):
            v = getattr(self, name)
            top = _UPPER.get(name)
            if isinstance(v, bool) or not isinstance(v, int) or v < 1 or (top and v > top):
                raise BridgeflapInputError(name, "must be a positive integer" + (
                    f" (at most {top})" if top else "") + f", got {v!r}")
        if self.omega_max_rad_s <= self.omega_min_rad_s:
            raise BridgeflapInputError("omega_max_rad_s", "must exceed omega_min_rad_s")
        if self.robust_omega_max_rad_s <= self.robust_omega_min_rad_s:
            raise BridgeflapInputError("robust_omega_max_rad_s",
                                       "must exceed robust_omega_min_rad_s")
        for name in ("a2_bounds", "a1_bounds"):
            b = getattr(self, name)
            if not (isinstance(b, tuple | list) and len(b) == 2):
                raise BridgeflapInputError(name, f"must be a pair [low, high], got {b!r}")
            if _num(name, b[0]) >= _num(name, b[1]):
                raise BridgeflapInputError(name, f"low must be below high, got {b!r}")
        pos = self.flap_positions_m
        if not isinstance(pos, tuple | list):
            raise BridgeflapInputError("flap_positions_m", f"must be a list of flap centres [m], "
                                                           f"got {pos!r}")
        for v in pos:
            _num("flap_positions_m", v)
        if len(set(float(v) for v in pos)) != len(pos):
            raise BridgeflapInputError("flap_positions_m", "has a flap centre twice")
        if len(pos) > 200:
            raise BridgeflapInputError("flap_positions_m", f"at most 200 flaps, got {len(pos)}")
        if pos:     # a subset of the candidates: placement, flap counts and checks share them
            grid = self.positions(self.flap_count) if isinstance(self.flap_count, int) and \
                self.flap_count > 0 else np.zeros(0)
            off = [float(v) for v in pos if not np.any(np.abs(grid - float(v)) < 1e-6)]
            if off:
                raise BridgeflapInputError(
                    "flap_positions_m", f"{off[0]:g} m is not a candidate position of "
                    f"{self.flap_count} flaps {self.flap_width_m:g} m wide about mid-span "
                    "(flap_positions_m = [] fits every candidate)")
        for v in self.min_flap_counts:
            if isinstance(v, bool) or not isinstance(v, int) or v < 1:
                raise BridgeflapInputError("min_flap_counts",
                                           f"must be positive integers, got {v!r}")
        if self.a2_bounds[0] <= 0 or self.a1_bounds[0] <= 0:
            raise BridgeflapInputError("a2_bounds", "lower bounds of a2 and a1 must be > 0 "
                                                    "(stable, proper compensator)")
        if not (self.leading_edge or self.trailing_edge):
            raise BridgeflapInputError("trailing_edge", "no flap fitted")
        for name in ("robust_design_speeds_m_s", "robust_speeds_m_s", "buffeting_speeds_m_s",
                     "actuator_design_speeds_m_s"):
            for v in getattr(self, name):
                _num(name, v, positive=True)
            if self.weight_robust > 0 and name.startswith("robust") and not getattr(self, name):
                # an empty list ran the design 30 s, then failed on a broadcast
                raise BridgeflapInputError(name, "needs at least one speed while weight_robust "
                                                 "> 0 (or set weight_robust = 0)")
        for name in ("optimise_placement", "leading_edge", "trailing_edge", "parallel",
                     "pareto", "symmetric_layout", "design_for_pair_failure",
                     "layout_neighbours", "layout_adopt"):
            if not isinstance(getattr(self, name), bool):
                raise BridgeflapInputError(name, f"must be true or false, got "
                                                 f"{getattr(self, name)!r}")
        if self.layout_adopt and not self.layout_neighbours:
            raise BridgeflapInputError("layout_adopt", "needs layout_neighbours = true (the "
                                                       "neighbour comparison it adopts from)")
        _num("b_bound", self.b_bound, positive=True)
        if not 0 < _num("robust_cut_tol", self.robust_cut_tol) <= 0.1:
            raise BridgeflapInputError("robust_cut_tol", "must be in (0, 0.1] (relative gap "
                                       f"of the robust bound), got {self.robust_cut_tol!r}")
        for name in ("seed", "cutting_plane_rounds"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int) or v < 0:
                raise BridgeflapInputError(name, f"must be an integer >= 0, got {v!r}")
        v = self.placement_cut_rounds
        if isinstance(v, bool) or not isinstance(v, int) or v < -1:
            raise BridgeflapInputError("placement_cut_rounds", "must be an integer >= 0, or -1 "
                                       f"(as cutting_plane_rounds), got {v!r}")
        if not isinstance(self.bridge, str) or not self.bridge:
            raise BridgeflapInputError("bridge", f"must be a bridge name or path, got "
                                                 f"{self.bridge!r}")
        for name in ("variants", "fresh_variants", "variant_seed"):
            v = getattr(self, name)
            top = _UPPER.get(name)
            if isinstance(v, bool) or not isinstance(v, int) or v < 0 or (top and v > top):
                raise BridgeflapInputError(name, "must be an integer >= 0" + (
                    f" and at most {top}" if top else "") + f", got {v!r}")
        if self.variant_speeds not in ("lazy", "all"):
            raise BridgeflapInputError("variant_speeds", "must be 'lazy' (constraint generation "
                                       "over variant and speed, "
                                       "bridgeflap.design.control.formulation.variants) or 'all', "
                                       f"got {self.variant_speeds!r}")
        if self.variant_rule not in VARIANT_RULES:
            raise BridgeflapInputError("variant_rule", "must be 'no_harm' (each variant damped "
                                       "below its own open-loop critical speed) or 'stable' "
                                       f"(damped 0..speed_max_m_s), got {self.variant_rule!r}")
        from bridgeflap.design.control.uncertainty import DEFAULT_UNCERTAIN_RANGES

        for v in self.variant_corners:
            if v not in DEFAULT_UNCERTAIN_RANGES or v in self.variant_fixed:
                raise BridgeflapInputError("variant_corners", "must name uncertain inputs ("
                                           + ", ".join(k for k in DEFAULT_UNCERTAIN_RANGES
                                                       if k not in self.variant_fixed)
                                           + f"), got {v!r}")
        if len(self.variant_corners) > 4:
            raise BridgeflapInputError("variant_corners", "at most 4 inputs (16 corners), got "
                                       f"{len(self.variant_corners)}")
        if not 0 <= _num("compensator_damping_min", self.compensator_damping_min) < 1:
            raise BridgeflapInputError("compensator_damping_min", "must be in [0, 1), got "
                                       f"{self.compensator_damping_min!r}")
        if not 0 <= _num("layout_dead_band", self.layout_dead_band) < 0.5:
            raise BridgeflapInputError("layout_dead_band", "must be in [0, 0.5), got "
                                       f"{self.layout_dead_band!r}")
        if self.buffeting_term not in ("modal", "callback", "casadi"):
            raise BridgeflapInputError("buffeting_term", "must be 'modal' (CasADi spectral "
                                       "integral in modal coordinates), 'casadi' (on the state "
                                       "matrix) or 'callback' (numpy, forward differences), "
                                       f"got {self.buffeting_term!r}")
        if (isinstance(self.flap_budget, bool) or not isinstance(self.flap_budget, int)
                or not 0 <= self.flap_budget <= self.flap_count):
            raise BridgeflapInputError("flap_budget", "must be an integer in 0..flap_count "
                                                      f"(0: no budget), got {self.flap_budget!r}")

        if self.objective not in OBJECTIVES:
            raise BridgeflapInputError("objective", f"must be one of {', '.join(OBJECTIVES)}, "
                                                    f"got {self.objective!r}")
        _num("margin_min", self.margin_min, positive=True)
        for name in ("critical_speed_step_m_s", "critical_speed_tol_m_s"):
            _num(name, getattr(self, name), positive=True)
        _num("critical_speed_max_m_s", self.critical_speed_max_m_s, nonneg=True)
        v = self.critical_speed_evaluations
        if isinstance(v, bool) or not isinstance(v, int) or v < 2:
            raise BridgeflapInputError("critical_speed_evaluations",
                                       f"must be an integer >= 2, got {v!r}")
        if self.objective == "critical_speed":
            if self.critical_speed_tol_m_s >= self.critical_speed_step_m_s:
                raise BridgeflapInputError("critical_speed_tol_m_s",
                                           "must be below critical_speed_step_m_s")
            if 0 < self.critical_speed_max_m_s < self.speed_max_m_s:
                raise BridgeflapInputError("critical_speed_max_m_s",
                                           "must be >= speed_max_m_s, where the search "
                                           "starts (0: 2 speed_max_m_s)")
            if self.weight_robust <= 0 or not self.robust_speeds_m_s:
                raise BridgeflapInputError("weight_robust", "the critical-speed objective "
                                           "needs the robust margin (weight_robust > 0 and "
                                           "robust_speeds_m_s)")

    def positions(self, count: int | None = None) -> np.ndarray:
        """Flap centres from the main-span mid-point [m]: ``flap_positions_m`` when given (and
        ``count`` is not), else ``count`` (default ``flap_count``) evenly spaced, touching.

        Parameters
        ----------
        count : int, optional
            Evenly spaced flaps to lay out (default: ``flap_positions_m`` when given, else
            ``flap_count``).

        Returns
        -------
        numpy.ndarray
            The flap centres [m], sorted.
        """
        if count is None and self.flap_positions_m:
            return np.sort(np.asarray(self.flap_positions_m, float))
        count = self.flap_count if count is None else int(count)
        return (np.arange(count) - 0.5 * (count - 1)) * self.flap_width_m

    def design_speeds(self) -> np.ndarray:
        """Design grid [m/s], 0 .. speed_max inclusive (never above it: the steps that fit,
        then ``speed_max``).

        Returns
        -------
        numpy.ndarray
            Speeds [m/s] in steps of ``design_step_m_s``, ending at ``speed_max_m_s``.
        """
        n = int(np.floor(self.speed_max_m_s / self.design_step_m_s + 1e-9))
        return np.unique(np.append(np.linspace(0.0, n * self.design_step_m_s, n + 1),
                                   self.speed_max_m_s))

    def iteration_cap(self) -> int:
        """Most Ipopt iterations of one start (the total of its progress bar): phase 1 and
        round 0 (``max_iter`` each) and the cut re-solves (``resolve_max_iter`` each); twice
        that with ``optimise_placement`` (the rounded layout is solved again).

        Returns
        -------
        int
            The iteration count.
        """
        once = 2 * self.max_iter + self.cutting_plane_rounds * self.resolve_max_iter
        return once * (2 if self.optimise_placement else 1)

    def check_speeds(self) -> np.ndarray:
        """Dense verification grid [m/s].

        Returns
        -------
        numpy.ndarray
            Evenly spaced speeds [m/s] from 0 to ``speed_max_m_s``, about ``check_step_m_s``
            apart.
        """
        n = int(round(self.speed_max_m_s / self.check_step_m_s))
        return np.linspace(0.0, self.speed_max_m_s, n + 1)



_TOML_KEYS = {f for f in DesignSettings.__dataclass_fields__ if f != "extras"}


def load_settings(path: str | os.PathLike | None = "default", **overrides) -> DesignSettings:
    """A design card (TOML) read into :class:`DesignSettings`, keywords overriding its keys.

    Parameters
    ----------
    path : str, path-like or None, default "default"
        ``"default"`` (or no argument): the packaged card :data:`DEFAULT_CARD`
        (``design/studies/humber_flaps.toml``), the one ``bridgeflap optimise`` runs without a
        card; a path: your card (docs/reference/formats/card.md); ``None``: no card, the bare
        :class:`DesignSettings` defaults (no flap positions, no scenario bridges, no buffeting
        term).
    **overrides
        Card keys and their values (units in the key names, e.g. ``speed_max_m_s=80.0``); they
        replace the card's.

    Returns
    -------
    DesignSettings
        The validated settings.

    Raises
    ------
    BridgeflapInputError
        Unknown key (with the closest known ones), bad value, missing or unreadable file.

    Examples
    --------
    >>> from bridgeflap import design
    >>> card = design.load_settings()                   # the packaged card
    >>> len(card.flap_positions_m), card.weight_buffeting
    (11, 3.0)
    >>> bare = design.load_settings(None, n_modes=8)    # no card: the bare defaults
    >>> bare.flap_positions_m, bare.n_modes
    ((), 8)
    """
    check_load_settings_args(path, overrides)
    data = {}
    if isinstance(path, str) and path == "default":
        path = DEFAULT_CARD
    if path is not None:
        p = Path(path)
        try:
            data = tomllib.loads(p.read_text(encoding="utf-8"))
        except FileNotFoundError:
            raise BridgeflapInputError("design", f"file not found: {p}") from None
        except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
            raise BridgeflapInputError("design", f"invalid TOML in {p}: {exc}") from None
        except OSError as exc:  # a folder, no permission
            raise BridgeflapInputError("design", f"cannot read {p}: {exc}") from None
    flat = {}
    for key, value in data.items():
        if isinstance(value, dict):         # allow [tables] for grouping
            for k, v in value.items():
                flat[k] = v
        else:
            flat[key] = value
    flat.update(overrides)
    unknown = sorted(set(flat) - _TOML_KEYS)
    if unknown:
        import difflib

        close = difflib.get_close_matches(unknown[0], sorted(_TOML_KEYS), n=3)
        raise BridgeflapInputError(unknown[0], "unknown design setting" + (
            f" (did you mean {', '.join(close)}?)" if close else
            f" (the {len(_TOML_KEYS)} known ones: "
            f"bridgeflap.design.control.settings.DesignSettings, "
            "documented in runs/humber_flaps.toml)"))
    for key in ("a2_bounds", "a1_bounds", "min_flap_counts", "robust_speeds_m_s", "variant_fixed",
                "variant_corners", "flap_positions_m",
                "robust_design_speeds_m_s", "buffeting_speeds_m_s", "actuator_design_speeds_m_s"):
        if key in flat:
            if not isinstance(flat[key], list | tuple):
                raise BridgeflapInputError(key, f"must be a list, got {flat[key]!r}")
            flat[key] = tuple(flat[key])
    return DesignSettings(**flat)


#: The packaged design cards (shipped in the wheel).
CARDS_DIR = Path(__file__).resolve().parents[1] / "studies"

#: The card `bridgeflap optimise` and the default study's design step run.
DEFAULT_CARD = CARDS_DIR / "humber_flaps.toml"


def packaged_card(name) -> Path:
    """The path of a card: a file name of ``design/studies`` (``"humber_flaps.toml"``, with
    or without the suffix; ``"default"`` is :data:`DEFAULT_CARD`) or any existing path."""
    if str(name) == "default":
        return DEFAULT_CARD
    p = Path(name)
    if p.exists():
        return p
    q = CARDS_DIR / (p.name if p.suffix == ".toml" else p.name + ".toml")
    if str(name) == p.name and q.exists():
        return q
    known = ", ".join(sorted(c.stem for c in CARDS_DIR.glob("*.toml")))
    raise BridgeflapInputError("card", f"no card {name!r} (packaged: default, {known})")


def quick_settings(settings: DesignSettings) -> DesignSettings:
    """Reduced settings of a card, as ``bridgeflap optimise --quick`` and CI use them.

    One start, a design grid of at least 10 m/s, two cut rounds, fewer flap counts, and of a
    scenario design the corners only (no Sobol' draws). On the packaged card the design takes
    about a minute on 2 cores (docs/background/benchmarks.md).

    Two rounds, not one: on humber:box the first re-solve after the cuts can stop at its
    iteration cap 4.6e-6 1/s short of the damping at a design speed (status then infeasible); the
    second re-solve continues it. The design model keeps its modes (a design on 8 modes flutters
    at 79.75 m/s on the 16-mode model); the dense verification on ``verification_modes`` is
    unchanged and the status says whether it holds. The critical-speed search
    (``objective = "critical_speed"``) bisects to 2.5 m/s (at most half its step) instead of
    ``critical_speed_tol_m_s``.

    Parameters
    ----------
    settings : DesignSettings
        The full settings (e.g. :func:`load_settings`).

    Returns
    -------
    DesignSettings
        A reduced copy; ``settings`` is unchanged.

    Raises
    ------
    BridgeflapInputError
        ``settings`` is not valid.

    Examples
    --------
    >>> from bridgeflap import design
    >>> quick = design.quick_settings(design.load_settings())
    >>> quick.starts, quick.design_step_m_s, quick.cutting_plane_rounds
    (1, 10.0, 2)
    """
    check_settings(settings)
    tol = max(settings.critical_speed_tol_m_s, min(2.5, 0.5 * settings.critical_speed_step_m_s))
    return replace(settings, starts=1, design_step_m_s=max(settings.design_step_m_s, 10.0),
                   cutting_plane_rounds=2, min_flap_counts=(25, 13, 5), pareto=False,
                   critical_speed_tol_m_s=tol, variants=0)
