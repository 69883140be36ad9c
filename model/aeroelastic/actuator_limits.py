"""Flap actuator limits: the card keys, their defaults (engineering estimates) and checks.

Light on purpose (no NumPy-heavy imports): :mod:`bridgeflap.design.control.settings` validates the
design card's ``flap_angle_limit_deg`` and ``flap_rate_limit_deg_s`` with
:func:`check_actuator_value`, and
:mod:`bridgeflap.model.response.actuator_sim` simulates the saturated closed loop with them.

The defaults are **engineering estimates**, not a supplier's data sheet (docs/methods.md,
"Actuator limits and saturated closed loop in turbulence"):

* ``flap_angle_limit_deg = 20``: a 3 m flap at +-20 deg keeps its tip within ~1 m of the deck
  line, and +-20 deg is about the largest deflection for which the attached-flow thin-aerofoil
  flap loads used here (Theodorsen & Garrick, NACA TR-496) are still a fair model;
* ``flap_rate_limit_deg_s = 40``: hydraulic primary flight-control actuators move at 40-60
  deg/s; 40 is the lower end, derated for flaps some 50 m long;
* ``actuator_bandwidth_rad_s = 10`` (1.6 Hz): the servo's tracking bandwidth, well above the
  deck modes that matter (< 0.6 Hz) and the compensator's poles (~0.3 Hz); it acts only while
  the flap recovers from saturation (within the limits the flap follows ``K alpha`` exactly).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from bridgeflap.model.errors import BridgeflapInputError

__all__ = ["ACTUATOR_DEFAULTS", "ACTUATOR_FIELDS", "ACTUATOR_RANGES", "ActuatorLimits",
           "check_actuator_value"]

#: defaults of the card keys and CLI options (module docstring: engineering estimates)
ACTUATOR_DEFAULTS = {"flap_angle_limit_deg": 20.0, "flap_rate_limit_deg_s": 40.0,
                     "actuator_bandwidth_rad_s": 10.0}
#: the design-card keys (``DesignSettings`` fields)
ACTUATOR_FIELDS = ("flap_angle_limit_deg", "flap_rate_limit_deg_s")
#: plausible ranges (inclusive): far outside any flap actuator is refused, naming the field
ACTUATOR_RANGES = {"flap_angle_limit_deg": (1e-6, 90.0), "flap_rate_limit_deg_s": (1e-6, 1e4),
                   "actuator_bandwidth_rad_s": (0.1, 1e3)}


def check_actuator_value(name: str, value) -> float:
    """``value`` as float within :data:`ACTUATOR_RANGES` (``BridgeflapInputError`` naming it)."""
    lo, hi = ACTUATOR_RANGES[name]
    try:
        ok = not isinstance(value, bool) and math.isfinite(float(value))
    except (TypeError, ValueError):
        ok = False
    if not ok:
        raise BridgeflapInputError(name, f"must be a finite number, got {value!r}")
    v = float(value)
    if not lo <= v <= hi:
        raise BridgeflapInputError(name, f"must be in [{lo:g}, {hi:g}], got {value!r}")
    return v


@dataclass(frozen=True)
class ActuatorLimits:
    """Flap actuator limits: angle [deg], rate [deg/s], servo tracking bandwidth [rad/s]."""

    angle_deg: float = ACTUATOR_DEFAULTS["flap_angle_limit_deg"]
    rate_deg_s: float = ACTUATOR_DEFAULTS["flap_rate_limit_deg_s"]
    bandwidth_rad_s: float = ACTUATOR_DEFAULTS["actuator_bandwidth_rad_s"]

    def __post_init__(self):
        for attr, name in (("angle_deg", "flap_angle_limit_deg"),
                           ("rate_deg_s", "flap_rate_limit_deg_s"),
                           ("bandwidth_rad_s", "actuator_bandwidth_rad_s")):
            object.__setattr__(self, attr, check_actuator_value(name, getattr(self, attr)))

    def summary(self) -> dict:
        """The limits in the JSON (with their source)."""
        return {"flap_angle_limit_deg": self.angle_deg, "flap_rate_limit_deg_s": self.rate_deg_s,
                "actuator_bandwidth_rad_s": self.bandwidth_rad_s,
                "limits_source": "engineering estimate "
                "(bridgeflap.model.aeroelastic.actuator_limits; "
                                 "docs/methods.md#actuator-limits-and-saturated-closed-loop-in-turbulence)"}
