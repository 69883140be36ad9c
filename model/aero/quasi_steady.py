r"""Quasi-steady buffeting loads from static coefficients (Davenport 1962; Scanlan 1978).

Conventions of :mod:`bridgeflap.model` (SI units, heave ``h`` positive down, pitch ``alpha`` nose-up
about mid-chord, lateral ``p`` downwind) and of :mod:`bridgeflap.model.aero.derivatives` for the
coefficients: every coefficient here is normalised by the full deck width ``B = 2 b`` (lift up,
moment nose-up, drag downwind, per rad for the slopes). A drag coefficient stated on the deck depth
``D`` (``depth_m``, the usual wind-tunnel form) is converted once, ``C_D^B = C_D^D D / B``.

With along-wind turbulence ``u`` and vertical turbulence ``w`` (up), both small against the
mean wind ``U``, the relative wind comes in at ``phi = w / U`` with ``|V|^2 = U^2 + 2 U u``.
Linearising the steady loads ``1/2 rho |V|^2 B C(alpha + phi)`` in ``u`` and ``w`` and turning
them into the mean-wind axes gives, per unit length (Scanlan 1978, Eqs. (3)-(5); Simiu &
Scanlan 1996, Eq. (12.47); Strommen 2006, Eq. (5.12) with ``D/B C_D`` there = ``C_D^B``
here)::

    L_b = 1/2 rho U^2 B   [2 C_L u/U + (C_L' + C_D) w/U]          (up)
    M_b = 1/2 rho U^2 B^2 [2 C_M u/U +  C_M'        w/U]          (nose-up)
    D_b = 1/2 rho U^2 B   [2 C_D u/U + (C_D' - C_L) w/U]          (downwind)

Each line is ``U`` times a constant times the gust velocity, so the strip inputs keep the form
``B_w(U) = U Bw1`` of :class:`bridgeflap.model.aeroelastic.statespace.AeroelasticSystem`:
:func:`gust_inputs` returns the generalised loads per ``U`` and per unit gust velocity of the ``w``
and the ``u`` strips. The drag line acts on the lateral shapes when the basis has them (the
flutter-derivative basis of a modal bridge with lateral shapes), and is dropped otherwise; the
outputs stay strip heave and pitch.

Turbulence: ``w`` with the spectrum, admittance and Davenport coherence of
:class:`bridgeflap.model.aero.gust.GustField` (the existing vertical-gust path); ``u`` with the von
Karman along-wind spectrum (:func:`von_karman_u`, ``sigma_u = I_u U`` and ``L_u^x`` of the
``[static_coefficients]`` section), the same admittance and coherence decay, and no ``u``-``w``
cross-spectrum (the usual simplification; the IABSE step-2a windstate also leaves it out).
With ``C_D = C_L = C_M = C_D' = 0``, ``C_L' = 2 pi``, ``C_M' = pi/2`` the ``u`` loads vanish
and the ``w`` loads are exactly the thin-aerofoil buffeting loads of
:func:`bridgeflap.model.aero.strips.strip_aero` (``P_gust``), so the two paths agree
(``tests/test_quasi_steady.py``).

References
----------
.. [1] A. G. Davenport, "Buffetting of a suspension bridge by storm winds", J. Struct. Div.
   ASCE 88(ST3), 233-268, 1962.
.. [2] R. H. Scanlan, "The action of flexible bridges under wind, II: buffeting theory",
   J. Sound Vib. 60(2), 201-211, 1978.
.. [3] E. Simiu, R. H. Scanlan, *Wind Effects on Structures*, 3rd ed., Wiley, 1996, ch. 12.
.. [4] E. N. Strommen, *Theory of Bridge Aerodynamics*, Springer, 2006, ch. 5.
.. [5] T. von Karman, "Progress in the statistical theory of turbulence", PNAS 34, 530, 1948.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from bridgeflap.model.errors import BridgeflapInputError

__all__ = ["STATIC_KEYS", "StaticCoefficients", "gust_inputs", "static_from_dict",
           "von_karman_u"]

#: keys of a ``[static_coefficients]`` table (the names of the IABSE section cases' JSON)
STATIC_KEYS = ("C_D", "dC_D_drad", "C_L", "dC_L_drad", "C_M", "dC_M_drad", "depth_m",
               "turbulence_intensity_u", "length_scale_u_m", "source")


@dataclass(frozen=True)
class StaticCoefficients:
    """Static coefficients of the deck and the along-wind turbulence they need (module doc).

    ``C_L``, ``C_M`` and their slopes on ``B``; ``C_D`` and its slope on ``depth_m`` when it
    is given, else on ``B``; slopes per rad. ``turbulence_intensity_u`` ``sigma_u / U`` [-] and
    ``length_scale_u_m`` ``L_u^x`` [m] of the von Karman ``u`` spectrum.
    """

    C_D: float = 0.0
    dC_D_drad: float = 0.0
    C_L: float = 0.0
    dC_L_drad: float = 2 * math.pi
    C_M: float = 0.0
    dC_M_drad: float = math.pi / 2
    depth_m: float | None = None
    turbulence_intensity_u: float = 0.1
    length_scale_u_m: float = 200.0
    source: str = ""

    def __post_init__(self):
        for k in STATIC_KEYS[:6]:
            v = getattr(self, k)
            if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
                raise BridgeflapInputError(f"static_coefficients.{k}", f"must be a number, "
                                           f"got {v!r}")
        for k in ("depth_m", "turbulence_intensity_u", "length_scale_u_m"):
            v = getattr(self, k)
            if v is None and k == "depth_m":
                continue
            if isinstance(v, bool) or not isinstance(v, int | float) or not (
                    math.isfinite(v) and v > 0):
                raise BridgeflapInputError(f"static_coefficients.{k}", f"must be a positive "
                                           f"number, got {v!r}")
        if self.C_D < 0:
            raise BridgeflapInputError("static_coefficients.C_D", "must be >= 0")

    def on_width(self, chord_m: float) -> dict:
        """The six coefficients normalised by ``B = chord_m`` [-, per rad]."""
        f = 1.0 if self.depth_m is None else float(self.depth_m) / float(chord_m)
        return {"C_D": self.C_D * f, "dC_D": self.dC_D_drad * f, "C_L": self.C_L,
                "dC_L": self.dC_L_drad, "C_M": self.C_M, "dC_M": self.dC_M_drad}

    def summary(self, chord_m: float) -> dict:
        """JSON-ready inputs (coefficients on ``B``)."""
        c = self.on_width(chord_m)
        return {"static_coefficients_on_B": {k: float(v) for k, v in c.items()},
                "turbulence_intensity_u": float(self.turbulence_intensity_u),
                "length_scale_u_m": float(self.length_scale_u_m)}


def static_from_dict(table, where: str = "static_coefficients") -> StaticCoefficients:
    """A :class:`StaticCoefficients` from a bridge-file table (bare or ``{value, source}``)."""
    if not isinstance(table, dict):
        raise BridgeflapInputError(where, "must be a table")
    unknown = sorted(set(table) - set(STATIC_KEYS))
    if unknown:
        raise BridgeflapInputError(f"{where}.{unknown[0]}", "unknown key")
    kw, notes = {}, []
    for k, raw in table.items():
        if k == "source":
            if not isinstance(raw, str):
                raise BridgeflapInputError(f"{where}.source", "must be a string")
            notes.insert(0, raw)
            continue
        if isinstance(raw, dict):
            if set(raw) - {"value", "source"} or "value" not in raw:
                raise BridgeflapInputError(f"{where}.{k}", "give a number or {value, source}")
            notes.append(f"{k}: {raw.get('source', 'not stated')}")
            raw = raw["value"]
        if isinstance(raw, bool) or not isinstance(raw, int | float):
            raise BridgeflapInputError(f"{where}.{k}", f"must be a number, got {raw!r}")
        kw[k] = float(raw)
    try:
        return StaticCoefficients(**kw, source="; ".join(notes))
    except BridgeflapInputError as exc:  # name the field where it was written
        raise BridgeflapInputError(exc.field.replace("static_coefficients", where, 1),
                                   exc.reason) from None


def von_karman_u(intensity: float, length_scale_m: float):
    """One-sided along-wind spectrum in ``omega``, ``(omega [rad/s], U [m/s]) -> G_uu``.

    ``n S_u(n) / sigma_u^2 = 4 f / (1 + 70.8 f^2)^(5/6)``, ``f = n L_u / U`` (von Karman 1948;
    ESDU 74031), ``sigma_u = intensity U``; ``G(omega) = S(n) / (2 pi)``. Its integral is
    ``sigma_u^2`` to 5e-5 (the 70.8 is the rounded normalising constant).
    """
    Iu, L = float(intensity), float(length_scale_m)

    def von_karman_u_spectrum(omega, wind_speed):
        U = float(wind_speed)
        n = np.abs(np.asarray(omega, float)) / (2 * np.pi)
        f = n * L / U
        return (Iu * U) ** 2 * 4 * L / U / (1 + 70.8 * f * f) ** (5 / 6) / (2 * np.pi)

    return von_karman_u_spectrum


def gust_inputs(basis, chord_m: float, air_density: float, coeffs: StaticCoefficients,
                phi_p=None) -> tuple[np.ndarray, np.ndarray]:
    """Generalised buffeting loads per ``U`` per unit gust velocity: ``(P_w, P_u)``, (n, n_s).

    ``Q_j = U sum_i (P_w[j, i] w_i + P_u[j, i] u_i)`` with ``w_i`` (up) and ``u_i``
    (downwind) the gust velocities [m/s] of strip ``i`` (module docstring; the heave-down sign
    of :mod:`bridgeflap.model` applied to the lift), ``basis`` a
    :class:`~bridgeflap.model.aero.basis.StructuralBasis` and ``phi_p`` the strip lateral shapes
    (optional).
    """
    c = coeffs.on_width(chord_m)
    B, half_rho = float(chord_m), 0.5 * float(air_density)
    dl = np.asarray(basis.strip_length, float)[:, None]
    ph, pa = np.asarray(basis.phi_h, float), np.asarray(basis.phi_a, float)
    # per unit length per U: heave-down load, nose-up moment, downwind drag
    P_w = -half_rho * B * (c["dC_L"] + c["C_D"]) * ph + half_rho * B * B * c["dC_M"] * pa
    P_u = -half_rho * B * 2 * c["C_L"] * ph + half_rho * B * B * 2 * c["C_M"] * pa
    if phi_p is not None:
        pp = np.asarray(phi_p, float)
        P_w = P_w + half_rho * B * (c["dC_D"] - c["C_L"]) * pp
        P_u = P_u + half_rho * B * 2 * c["C_D"] * pp
    return (dl * P_w).T, (dl * P_u).T
