"""Vertical turbulence spectra, span-wise coherence and aerodynamic admittance.

Conventions of :mod:`bridgeflap.model` apply (SI units; ``k = omega b / U``). Spectra here are of
the vertical gust velocity ``w`` and are **one-sided in cyclic frequency** ``n`` [Hz] unless the
name says otherwise: ``sigma_w^2 = int_0^inf S_w(n) dn``. The paper's Eq. (15) is the same
Busch-Panofsky spectrum written **two-sided in circular frequency**,
``sigma_w^2 = int_{-inf}^{inf} S_w(omega) d omega``; see :func:`busch_panofsky_omega`.

References
----------
.. [1] N. E. Busch, H. A. Panofsky, "Recent spectra of atmospheric turbulence", Q. J. R.
   Meteorol. Soc. 94, 132-148, 1968.
.. [2] J. C. Kaimal, J. C. Wyngaard, Y. Izumi, O. R. Cote, "Spectral characteristics of
   surface-layer turbulence", Q. J. R. Meteorol. Soc. 98, 563-589, 1972.
.. [3] T. von Karman, "Progress in the statistical theory of turbulence", Proc. Natl. Acad.
   Sci. 34, 530-539, 1948; ESDU 85020 (1985) for the engineering form.
.. [4] A. G. Davenport, "The response of slender line-like structures to a gusty wind",
   Proc. ICE 23, 389-408, 1962 (exponential coherence).
.. [5] E. Simiu, R. H. Scanlan, *Wind Effects on Structures*, 3rd ed., Wiley, 1996, ch. 2.
.. [6] Massaro, Limebeer et al. (the paper), Eqs. (14)-(16).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.special import gamma

from bridgeflap.model.aero.theodorsen import (
    liepmann_admittance_sq,
    sears_admittance_sq,
    unit_admittance_sq,
)
from bridgeflap.model.errors import BridgeflapInputError

__all__ = [
    "ADMITTANCE_KINDS",
    "SPECTRUM_KINDS",
    "admittance_sq",
    "busch_panofsky",
    "busch_panofsky_omega",
    "busch_panofsky_variance_ratio",
    "coherence",
    "default_length_scale_w",
    "friction_velocity_from_intensity",
    "kaimal_variance_ratio",
    "kaimal_w",
    "vertical_spectrum",
    "von_karman_w",
]

SPECTRUM_KINDS: tuple[str, ...] = ("busch-panofsky", "von-karman", "kaimal")
"""Spectrum names accepted by :func:`vertical_spectrum`."""
ADMITTANCE_KINDS: tuple[str, ...] = ("liepmann", "sears", "unit")
"""Admittance names accepted by :func:`admittance_sq`."""

# n S_w / u*^2 = _A f / (1 + _B f^(5/3)), f = n z / U
_BP_A, _BP_B = 3.36, 10.0  # Busch & Panofsky (1968)
_KAIMAL_A, _KAIMAL_B = 2.0, 5.3  # Kaimal et al. (1972), w component
# von Karman constant a = Gamma(1/3) / (sqrt(pi) Gamma(5/6)) = 1.339; for w with the
# longitudinal integral scale L_w the spectrum uses (4 pi a x)^2 = 283.1 x^2 (ESDU: 283.2).
_VK_A = gamma(1.0 / 3.0) / (np.sqrt(np.pi) * gamma(5.0 / 6.0))
_VK_C = (4.0 * np.pi * _VK_A) ** 2


def _positive(field: str, value: float) -> float:
    """Return ``value`` as float, raising BridgeflapInputError unless finite and > 0."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise BridgeflapInputError(field, f"must be a positive number, got {value!r}") from None
    if not (np.isfinite(v) and v > 0.0):
        raise BridgeflapInputError(field, f"must be finite and > 0, got {value!r}")
    return v


def _frequency(n_hz: ArrayLike) -> NDArray[np.float64]:
    """Return ``n_hz`` as a float array, rejecting negative or NaN frequencies."""
    n = np.asarray(n_hz, dtype=float)
    if np.any(np.isnan(n)) or np.any(n < 0.0):
        raise BridgeflapInputError("frequency_hz", "one-sided spectra need n >= 0 [Hz]")
    return n


def _inertial_variance_ratio(a: float, b: float) -> float:
    """``int_0^inf a / (1 + b f^(5/3)) df``: the variance of ``n S / u*^2 = a f/(1 + b f^(5/3))``.

    Closed form of the integral: ``int_0^inf df / (1 + b f^p) = b^(-1/p) (pi/p) / sin(pi/p)``.
    """
    p = 5.0 / 3.0
    return float(a * b ** (-1.0 / p) * (np.pi / p) / np.sin(np.pi / p))


def busch_panofsky_variance_ratio() -> float:
    """Ratio ``sigma_w^2 / u*^2`` of the Busch-Panofsky spectrum (= 1.6728) [-].

    Returns
    -------
    float
        ``int_0^inf 3.36 / (1 + 10 f^(5/3)) df = 3.36 * 10^(-3/5) (3 pi / 5) / sin(3 pi / 5)``
        = 1.67278 [-]; the paper states "approximately 1.67" (text after Eq. (15)).

    Notes
    -----
    The integral is evaluated in closed form (a Beta-function integral), not hard-coded;
    the unit tests check it against adaptive quadrature of :func:`busch_panofsky`.
    """
    return _inertial_variance_ratio(_BP_A, _BP_B)


def kaimal_variance_ratio() -> float:
    """Ratio ``sigma_w^2 / u*^2`` of the Kaimal (1972) w-spectrum (= 1.4574) [-].

    Returns
    -------
    float
        ``int_0^inf 2 / (1 + 5.3 f^(5/3)) df`` [-], closed form as in
        :func:`busch_panofsky_variance_ratio`.
    """
    return _inertial_variance_ratio(_KAIMAL_A, _KAIMAL_B)


def friction_velocity_from_intensity(U: float, intensity: float) -> float:
    """Friction velocity giving ``sigma_w = intensity * U`` with the Busch-Panofsky spectrum.

    Parameters
    ----------
    U : float
        Mean wind speed [m/s], > 0.
    intensity : float
        Vertical turbulence intensity ``sigma_w / U`` [-], > 0.

    Returns
    -------
    float
        ``u* = intensity * U / sqrt(1.6728)`` [m/s] (``sigma_w^2 = 1.6728 u*^2``,
        :func:`busch_panofsky_variance_ratio`). For ``intensity = 0.07``, ``u* = 0.0541 U``.
    """
    U = _positive("wind_speed", U)
    intensity = _positive("intensity", intensity)
    return intensity * U / np.sqrt(busch_panofsky_variance_ratio())


def _inertial_form(n_hz, U, z, u_star, a, b) -> NDArray[np.float64]:
    """``S_w = u*^2 (z/U) a / (1 + b f^(5/3))``, ``f = n z / U``: the common form of the
    Busch-Panofsky and Kaimal vertical spectra (``n S / u*^2 = a f / (1 + b f^(5/3))``)."""
    U = _positive("wind_speed", U)
    z = _positive("height", z)
    u_star = _positive("friction_velocity", u_star)
    f = _frequency(n_hz) * z / U
    return u_star**2 * (z / U) * a / (1.0 + b * f ** (5.0 / 3.0))


def busch_panofsky(n_hz: ArrayLike, U: float, z: float, u_star: float) -> NDArray[np.float64]:
    r"""One-sided Busch-Panofsky spectrum of the vertical gust velocity.

    Parameters
    ----------
    n_hz : array_like
        Cyclic frequency ``n`` [Hz], ``>= 0``.
    U : float
        Mean wind speed at height ``z`` [m/s].
    z : float
        Height above ground or water [m].
    u_star : float
        Friction velocity [m/s].

    Returns
    -------
    ndarray
        ``S_w(n)`` [m^2/s^2/Hz], shape of ``n_hz``; ``int_0^inf S_w dn = 1.6728 u*^2``.

    Notes
    -----
    .. math:: \frac{n S_w(n)}{u_*^2} = \frac{3.36 f}{1 + 10 f^{5/3}}, \qquad f = \frac{n z}{U},

    evaluated as ``S_w = u*^2 (z/U) 3.36 / (1 + 10 f^(5/3))`` so that ``n = 0`` is finite.
    The ``-5/3`` roll-off is the Kolmogorov inertial subrange; ``f S`` peaks at
    ``f = 0.15^0.6 = 0.320``.

    References
    ----------
    Busch & Panofsky (1968); Simiu & Scanlan (1996), ch. 2; the paper's Eq. (15).
    """
    return _inertial_form(n_hz, U, z, u_star, _BP_A, _BP_B)


def busch_panofsky_omega(
    omega: ArrayLike, U: float, z: float, u_star: float
) -> NDArray[np.float64]:
    r"""Two-sided circular-frequency Busch-Panofsky spectrum, the paper's Eq. (15).

    Parameters
    ----------
    omega : array_like
        Circular frequency [rad/s], either sign.
    U, z, u_star : float
        Mean wind speed [m/s], height [m] and friction velocity [m/s], as for
        :func:`busch_panofsky`.

    Returns
    -------
    ndarray
        ``S_w(omega)`` [m^2/s^2/(rad/s)], even in ``omega``;
        ``int_{-inf}^{inf} S_w(omega) d omega = sigma_w^2 = 1.6728 u*^2``.

    Notes
    -----
    The paper's Eq. (15):

    .. math:: S_w(\omega) = \frac{2\pi}{\omega} u_*^2
              \frac{3.36 f}{1 + 10 f^{5/3}} \frac{1}{4\pi},
              \qquad f = \frac{\omega z}{2 \pi U},

    i.e. ``S_w(omega) = S_w^{one-sided}(n = |omega|/(2 pi)) / (4 pi)``: a factor 1/2 for two
    sides and 1/(2 pi) for ``d omega = 2 pi dn``. Both forms give the same variance.
    """
    w = np.asarray(omega, dtype=float)
    if np.any(np.isnan(w)):
        raise BridgeflapInputError("omega", "contains NaN")
    return busch_panofsky(np.abs(w) / (2.0 * np.pi), U, z, u_star) / (4.0 * np.pi)


def kaimal_w(n_hz: ArrayLike, U: float, z: float, u_star: float) -> NDArray[np.float64]:
    r"""One-sided Kaimal (1972) spectrum of the vertical gust velocity (neutral surface layer).

    Parameters
    ----------
    n_hz : array_like
        Cyclic frequency [Hz], ``>= 0``.
    U : float
        Mean wind speed at height ``z`` [m/s].
    z : float
        Height [m].
    u_star : float
        Friction velocity [m/s].

    Returns
    -------
    ndarray
        ``S_w(n)`` [m^2/s^2/Hz]; ``int_0^inf S_w dn = 1.4574 u*^2``
        (:func:`kaimal_variance_ratio`).

    Notes
    -----
    .. math:: \frac{n S_w(n)}{u_*^2} = \frac{2 f}{1 + 5.3 f^{5/3}}, \qquad f = \frac{n z}{U}.

    References
    ----------
    Kaimal et al. (1972), Q. J. R. Meteorol. Soc. 98; Simiu & Scanlan (1996), ch. 2.
    """
    return _inertial_form(n_hz, U, z, u_star, _KAIMAL_A, _KAIMAL_B)


def von_karman_w(
    n_hz: ArrayLike, U: float, sigma_w: float, length_scale: float
) -> NDArray[np.float64]:
    r"""One-sided von Karman spectrum of the vertical gust velocity.

    Parameters
    ----------
    n_hz : array_like
        Cyclic frequency [Hz], ``>= 0``.
    U : float
        Mean wind speed [m/s].
    sigma_w : float
        Standard deviation of ``w`` [m/s].
    length_scale : float
        Longitudinal integral length scale of ``w``, ``L_w^x`` [m].

    Returns
    -------
    ndarray
        ``S_w(n)`` [m^2/s^2/Hz]; ``int_0^inf S_w dn = sigma_w^2`` exactly.

    Notes
    -----
    .. math:: \frac{n S_w(n)}{\sigma_w^2} = \frac{4 x (1 + \tfrac{8}{3} (4 \pi a x)^2)}
              {(1 + (4 \pi a x)^2)^{11/6}}, \qquad x = \frac{n L_w^x}{U},

    with ``a = Gamma(1/3) / (sqrt(pi) Gamma(5/6)) = 1.339``, so ``(4 pi a)^2 = 283.1`` and
    ``(8/3)(4 pi a)^2 = 755.0`` (ESDU's rounded 283.2 and 755.2). With the exact ``a`` the
    variance integral is exactly ``sigma_w^2``.

    References
    ----------
    von Karman (1948); ESDU 85020; Simiu & Scanlan (1996), section 2.3.
    """
    U = _positive("wind_speed", U)
    sigma_w = _positive("sigma_w", sigma_w)
    length_scale = _positive("length_scale", length_scale)
    n = _frequency(n_hz)
    y = _VK_C * (n * length_scale / U) ** 2
    return sigma_w**2 * (4.0 * length_scale / U) * (1.0 + 8.0 / 3.0 * y) / (1.0 + y) ** (11.0 / 6.0)


def default_length_scale_w(z: float) -> float:
    """Estimated integral length scale ``L_w^x`` of vertical turbulence at height ``z`` [m].

    Parameters
    ----------
    z : float
        Height above ground or water [m].

    Returns
    -------
    float
        ``L_w^x = 0.331 z`` [m]: the value at which the von Karman ``n S_w`` peak
        (``n L/U = 0.1059``) falls at the Busch-Panofsky peak (``n z/U = 0.15^0.6 = 0.3204``).

    Notes
    -----
    This is an **estimate** [DERIVED], chosen to make the von Karman option consistent with
    the paper's Busch-Panofsky spectrum; it is not a measured Humber value. For comparison, the
    Eurocode/N400-type rule ``L_w = L_u / 12`` gives about 11 m (0.36 z) at ``z = 30`` m over
    water. Pass ``length_scale`` explicitly when site data are available.
    """
    z = _positive("height", z)
    # von Karman peak: y = c x^2 solves 16 y^2 - 48 y - 9 = 0 (d/dx log(n S) = 0).
    y_peak = (48.0 + np.sqrt(48.0**2 + 4.0 * 16.0 * 9.0)) / 32.0
    x_peak = np.sqrt(y_peak / _VK_C)
    # Busch-Panofsky peak: 10 f^(5/3) = 3/2.
    f_peak = (1.5 / _BP_B) ** 0.6
    return float(x_peak / f_peak * z)


def vertical_spectrum(
    kind: str, n_hz: ArrayLike, U: float, z: float, intensity: float, **kw: float
) -> NDArray[np.float64]:
    """One-sided vertical gust spectrum of a named model, scaled to ``sigma_w = intensity U``.

    Parameters
    ----------
    kind : {"busch-panofsky", "von-karman", "kaimal"}
        Spectrum model (case and ``_``/``-`` insensitive).
    n_hz : array_like
        Cyclic frequency [Hz], ``>= 0``.
    U : float
        Mean wind speed at deck height [m/s], > 0.
    z : float
        Deck height above water [m], > 0.
    intensity : float
        Vertical turbulence intensity ``sigma_w / U`` [-], > 0.
    **kw
        ``length_scale`` [m] for ``"von-karman"`` only (default
        :func:`default_length_scale_w`); no other keywords are accepted.

    Returns
    -------
    ndarray
        ``S_w(n)`` [m^2/s^2/Hz] with ``int_0^inf S_w dn = (intensity U)^2`` for every kind.

    Raises
    ------
    BridgeflapInputError
        Unknown ``kind`` (field ``"spectrum"``), unknown keyword, or non-positive
        ``U``, ``z``, ``intensity``.

    Notes
    -----
    Busch-Panofsky and Kaimal are surface-layer similarity forms in ``u*``; ``u*`` is chosen
    as ``sigma_w / sqrt(ratio)`` with the spectrum's own variance ratio (1.6728 and 1.4574).
    """
    key = kind.strip().lower().replace("_", "-") if isinstance(kind, str) else kind
    if key not in SPECTRUM_KINDS:
        raise BridgeflapInputError(
            "spectrum", f"unknown kind {kind!r}; expected one of {SPECTRUM_KINDS}"
        )
    U = _positive("wind_speed", U)
    z = _positive("height", z)
    intensity = _positive("intensity", intensity)
    allowed = {"length_scale"} if key == "von-karman" else set()
    extra = set(kw) - allowed
    if extra:
        raise BridgeflapInputError(
            "spectrum", f"keyword(s) {sorted(extra)} not accepted by {key!r}"
        )
    sigma_w = intensity * U
    if key == "busch-panofsky":
        u_star = sigma_w / np.sqrt(busch_panofsky_variance_ratio())
        return busch_panofsky(n_hz, U, z, u_star)
    if key == "kaimal":
        u_star = sigma_w / np.sqrt(kaimal_variance_ratio())
        return kaimal_w(n_hz, U, z, u_star)
    length_scale = kw.get("length_scale", default_length_scale_w(z))
    return von_karman_w(n_hz, U, sigma_w, length_scale)


def coherence(
    n_hz: ArrayLike, separation: ArrayLike, U: float, decay: float
) -> NDArray[np.float64]:
    """Davenport exponential coherence of ``w`` between two points across the wind.

    Parameters
    ----------
    n_hz : array_like
        Cyclic frequency [Hz], ``>= 0``.
    separation : array_like
        Span-wise separation ``dy`` [m] (its absolute value is used); broadcast with ``n_hz``.
    U : float
        Mean wind speed [m/s], > 0.
    decay : float
        Decay constant ``c`` [-], ``>= 0``. Not given in the paper; 6-10 is a common range for
        ``w`` (docs/humber_data.md#turbulence-spectrum-and-coherence, treat as
        a sensitivity parameter).

    Returns
    -------
    ndarray
        ``exp(-c n |dy| / U)`` [-], in ``(0, 1]``: 1 at zero separation or zero frequency.

    Notes
    -----
    The paper's Eq. (16): ``S_{w1 w2} = S_w exp(-c L12 omega / (2 pi U))`` with ``omega = 2 pi n``.
    This real exponential is the (root-)coherence that multiplies the auto-spectrum.

    References
    ----------
    Davenport (1962); the paper's Eq. (16).
    """
    U = _positive("wind_speed", U)
    decay = float(decay)
    if not (np.isfinite(decay) and decay >= 0.0):
        raise BridgeflapInputError("decay", f"must be finite and >= 0, got {decay!r}")
    n = _frequency(n_hz)
    dy = np.abs(np.asarray(separation, dtype=float))
    return np.exp(-decay * n * dy / U)


def admittance_sq(kind: str, k: ArrayLike) -> NDArray[np.float64]:
    """Squared aerodynamic admittance ``|chi(k)|^2`` of a named model [-].

    Parameters
    ----------
    kind : {"liepmann", "sears", "unit"}
        ``"sears"``: exact ``|S(k)|^2``; ``"liepmann"``: ``1 / (1 + 2 pi k)``;
        ``"unit"``: 1 (quasi-steady).
    k : array_like
        Reduced frequency ``k = omega b / U`` [-].

    Returns
    -------
    ndarray
        ``|chi(k)|^2`` [-], shape of ``k``.

    Raises
    ------
    BridgeflapInputError
        Unknown ``kind`` (field ``"admittance"``).

    References
    ----------
    Sears (1941); Liepmann (1952); the paper's Eq. (14) (``chi_Lw = chi_Mw``).
    """
    key = kind.strip().lower() if isinstance(kind, str) else kind
    funcs = {
        "liepmann": liepmann_admittance_sq,
        "sears": sears_admittance_sq,
        "unit": unit_admittance_sq,
    }
    if key not in funcs:
        raise BridgeflapInputError(
            "admittance", f"unknown kind {kind!r}; expected one of {ADMITTANCE_KINDS}"
        )
    return np.asarray(funcs[key](k), dtype=float)
