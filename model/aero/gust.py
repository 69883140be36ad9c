"""Wind input of the buffeting analysis: the vertical gust field and its coherence.

Spectra are one-sided in circular frequency (:mod:`bridgeflap.model.spectral`); conventions of
:mod:`bridgeflap.model`. ``G_ww(omega) = s_w(omega) chi^2(k) R(omega)`` with ``R_ij = exp(-c n |y_i
- y_j| / U)``, ``n = omega / 2 pi`` (the paper's Eqs. (13)-(16); Davenport 1962); the spectra and
  admittances
are those of :mod:`bridgeflap.model.aero.wind`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from bridgeflap.model.aero.wind import (
    ADMITTANCE_KINDS,
    SPECTRUM_KINDS,
    admittance_sq,
    vertical_spectrum,
)
from bridgeflap.model.errors import BridgeflapInputError

__all__ = ["GustField", "coherence_projection", "gust_field"]


@dataclass(frozen=True)
class GustField:
    """Vertical-turbulence and buffeting-load inputs, validated.

    Attributes
    ----------
    spectrum : str or callable
        Name in :data:`bridgeflap.model.aero.wind.SPECTRUM_KINDS`, or ``(omega [rad/s], U [m/s]) ->
        G`` one-sided in ``omega`` [m^2/s^2 per rad/s] (used for analytic checks).
    admittance : str or callable
        Name in :data:`bridgeflap.model.aero.wind.ADMITTANCE_KINDS`, or ``k -> |chi(k)|^2`` [-].
    turbulence_intensity : float
        ``sigma_w / U`` [-], > 0 (seed: 0.07).
    deck_height_m : float
        Deck height above water ``z`` [m] (Busch-Panofsky and Kaimal scale with ``n z / U``).
    coherence_decay : float
        Davenport decay constant ``c`` [-], >= 0 (0: full span-wise coherence).
    half_chord_m : float
        ``b`` [m], for ``k = omega b / U`` in the admittance.
    length_scale_m : float or None
        ``L_w^x`` [m] for the von Karman spectrum
        (default :func:`bridgeflap.model.aero.wind.default_length_scale_w`).
    """

    spectrum: str | Callable = "busch-panofsky"
    admittance: str | Callable = "liepmann"
    turbulence_intensity: float = 0.07
    deck_height_m: float = 30.0
    coherence_decay: float = 8.0
    half_chord_m: float = 11.0
    length_scale_m: float | None = None

    def __post_init__(self):
        if isinstance(self.spectrum, str):
            key = self.spectrum.strip().lower().replace("_", "-")
            if key not in SPECTRUM_KINDS:
                raise BridgeflapInputError(
                    "spectrum", f"unknown kind {self.spectrum!r}; expected one of {SPECTRUM_KINDS}")
            object.__setattr__(self, "spectrum", key)
        elif not callable(self.spectrum):
            raise BridgeflapInputError("spectrum", "must be a name or a callable")
        if isinstance(self.admittance, str):
            key = self.admittance.strip().lower()
            if key not in ADMITTANCE_KINDS:
                raise BridgeflapInputError(
                    "admittance",
                    f"unknown kind {self.admittance!r}; expected one of {ADMITTANCE_KINDS}")
            object.__setattr__(self, "admittance", key)
        elif not callable(self.admittance):
            raise BridgeflapInputError("admittance", "must be a name or a callable")
        for name in ("turbulence_intensity", "deck_height_m", "half_chord_m"):
            v = getattr(self, name)
            if not (isinstance(v, int | float) and np.isfinite(v) and v > 0):
                raise BridgeflapInputError(name, f"must be finite and > 0, got {v!r}")
        c = self.coherence_decay
        if not (isinstance(c, int | float) and np.isfinite(c) and c >= 0):
            raise BridgeflapInputError("coherence_decay", f"must be finite and >= 0, got {c!r}")
        if self.length_scale_m is not None and not (
                np.isfinite(self.length_scale_m) and self.length_scale_m > 0):
            raise BridgeflapInputError("length_scale_m", "must be finite and > 0")

    def psd(self, omega, wind_speed: float) -> np.ndarray:
        """One-sided gust PSD ``s_w(omega)`` [m^2/s^2 per rad/s] (admittance not included)."""
        omega = np.abs(np.asarray(omega, dtype=float))
        if callable(self.spectrum):
            return np.asarray(self.spectrum(omega, wind_speed), dtype=float) * np.ones_like(omega)
        kw = {} if self.length_scale_m is None or self.spectrum != "von-karman" else {
            "length_scale": self.length_scale_m}
        # one-sided in n [Hz] -> one-sided in omega: G(omega) = S(n) dn/domega = S(n) / (2 pi)
        return vertical_spectrum(self.spectrum, omega / (2 * np.pi), wind_speed,
                                 self.deck_height_m, self.turbulence_intensity, **kw) / (2 * np.pi)

    def admittance_sq(self, omega, wind_speed: float) -> np.ndarray:
        """``|chi(k)|^2`` at ``k = omega b / U`` [-]."""
        k = np.abs(np.asarray(omega, dtype=float)) * self.half_chord_m / float(wind_speed)
        if callable(self.admittance):
            return np.asarray(self.admittance(k), dtype=float) * np.ones_like(k)
        return admittance_sq(self.admittance, k)

    def summary(self) -> dict:
        """JSON-ready description of the inputs."""
        def name(v):
            return v if isinstance(v, str) else getattr(v, "__name__", "callable")

        return {"spectrum": name(self.spectrum), "admittance": name(self.admittance),
                "turbulence_intensity": float(self.turbulence_intensity),
                "deck_height_m": float(self.deck_height_m),
                "coherence_decay": float(self.coherence_decay),
                "half_chord_m": float(self.half_chord_m),
                "length_scale_m": self.length_scale_m}


def gust_field(spec=None, **overrides) -> GustField:
    """A :class:`GustField` from ``spec.aero`` and ``spec.deck``; non-None keywords override."""
    base = {}
    if spec is not None:
        base = {"turbulence_intensity": spec.aero.turbulence_intensity,
                "deck_height_m": spec.aero.deck_height_m,
                "coherence_decay": spec.aero.coherence_decay,
                "half_chord_m": spec.deck.half_chord_m}
    base.update({k: v for k, v in overrides.items() if v is not None})
    return GustField(**base)


# ----------------------------------------------------------------------------------------------
# numerical kernels
# ----------------------------------------------------------------------------------------------
def coherence_projection(positions, V, omegas, wind_speed, decay) -> np.ndarray:
    """``V^T R(omega) V`` for the exponential coherence, by an O(m) recursion per frequency.

    Parameters
    ----------
    positions : array_like, shape (m,)
        Strip coordinates along the span [m] (any order).
    V : array_like, shape (m, r)
        Projection (real).
    omegas : array_like, shape (n_omega,)
        Circular frequencies [rad/s], >= 0.
    wind_speed : float
        ``U`` [m/s], > 0.
    decay : float
        Decay constant ``c`` [-], >= 0.

    Returns
    -------
    ndarray, shape (n_omega, r, r)
        Real symmetric ``V^T R V`` with ``R_ij = exp(-c omega |y_i - y_j| / (2 pi U))``
        (the paper's Eq. (16)).

    Notes
    -----
    For sorted ``y`` the matrix ``R`` is the covariance of a first-order Markov process in
    ``y``, so ``(R v)_i = f_i + g_i - v_i`` with ``f_i = v_i + a_i f_{i-1}`` and
    ``g_i = v_i + a_{i+1} g_{i+1}``, ``a_i = exp(-c omega (y_i - y_{i-1}) / (2 pi U))``.
    """
    y = np.asarray(positions, dtype=float).ravel()
    V = np.asarray(V, dtype=float)
    order = np.argsort(y, kind="stable")
    y, V = y[order], V[order]
    omegas = np.asarray(omegas, dtype=float).ravel()
    m = y.size
    a = np.exp(-float(decay) * np.abs(omegas)[:, None] * np.diff(y)[None, :]
               / (2 * np.pi * float(wind_speed)))  # (n_omega, m-1)
    # scan along the span with the frequency axis inside: (m, n_omega, r) keeps slices contiguous
    a = np.ascontiguousarray(a.T)  # (m-1, n_omega)
    f = np.empty((m, omegas.size, V.shape[1]))
    g = np.empty_like(f)
    f[0] = V[0]
    for i in range(1, m):
        np.multiply(a[i - 1, :, None], f[i - 1], out=f[i])
        f[i] += V[i]
    g[m - 1] = V[m - 1]
    for i in range(m - 2, -1, -1):
        np.multiply(a[i, :, None], g[i + 1], out=g[i])
        g[i] += V[i]
    f += g
    f -= V[:, None, :]  # R V, (m, n_omega, r)
    out = np.tensordot(V, f, axes=(0, 0)).transpose(1, 0, 2)  # (n_omega, r, r), one GEMM
    return 0.5 * (out + np.swapaxes(out, 1, 2))


