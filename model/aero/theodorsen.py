"""Exact unsteady thin-aerofoil functions: Theodorsen, Sears, T-functions for flaps.

Sign conventions (h down, alpha nose-up, moment about mid-chord, ``b`` half-chord,
``k = omega b / U``) are those stated once in :mod:`bridgeflap.model`; nothing here redefines them.
All functions are vectorised over the reduced frequency and use numpy/scipy only.

References
----------
.. [1] T. Theodorsen, "General theory of aerodynamic instability and the mechanism of
   flutter", NACA Report 496, 1935.
.. [2] W. R. Sears, "Some aspects of non-stationary airfoil theory and its practical
   application", J. Aeronaut. Sci. 8(3), 104-108, 1941.
.. [3] H. W. Liepmann, "On the application of statistical concepts to the buffeting
   problem", J. Aeronaut. Sci. 19(12), 793-800, 1952.
.. [4] R. L. Bisplinghoff, H. Ashley, R. L. Halfman, *Aeroelasticity*, Addison-Wesley,
   1955, sections 5-6 and 5-7.
.. [5] Massaro, Limebeer et al., "Flutter and buffeting of long span suspension bridges in
   fully erected and partially erected conditions" (the paper), Eqs. (2)-(4).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.special import hankel2, j0, j1, y0, y1

from bridgeflap.model.errors import BridgeflapInputError

__all__ = [
    "FlapSteadyCoefficients",
    "flap_steady_coefficients",
    "liepmann_admittance_sq",
    "sears",
    "sears_admittance_sq",
    "t_functions",
    "theodorsen",
    "theodorsen_scalar",
    "unit_admittance_sq",
]

# Below this reduced frequency C(k) is returned as exactly 1: the true value differs from 1 by
# O(k log k) < 1e-197, and the Hankel functions would overflow near the float64 limit.
_K_TINY = 1.0e-200
# Up to this k the scalar C(k) takes the real Bessel functions (agreeing with the Hankel form to
# 2e-15 relative); above it they lose relative accuracy (4e-13 at k = 1e4) and hankel2 is used.
_K_BESSEL = 10.0


def _reduced_frequency(k: ArrayLike) -> NDArray[np.float64]:
    """Return ``k`` as a float array, rejecting complex or NaN input."""
    arr = np.asarray(k)
    if np.iscomplexobj(arr):
        raise BridgeflapInputError("reduced_frequency", "must be real (k = omega b / U)")
    arr = arr.astype(float)
    if np.any(np.isnan(arr)):
        raise BridgeflapInputError("reduced_frequency", "contains NaN")
    return arr


def theodorsen(k: ArrayLike) -> np.complex128 | NDArray[np.complex128]:
    r"""Theodorsen's lift-deficiency function C(k), exact.

    Parameters
    ----------
    k : array_like
        Reduced frequency ``k = omega b / U`` [-], real. Negative ``k`` returns the complex
        conjugate (a real signal's spectrum); ``k = 0`` returns exactly 1 and ``k = inf``
        returns exactly 1/2.

    Returns
    -------
    complex or ndarray of complex
        ``C(k) = F(k) + i G(k)`` [-], same shape as ``k``.

    Notes
    -----
    With Hankel functions of the second kind (time factor ``exp(i omega t)``)

    .. math:: C(k) = \frac{H_1^{(2)}(k)}{H_1^{(2)}(k) + i H_0^{(2)}(k)},

    identical to the paper's Eq. (4),
    ``(J1 - i Y1) / ((J1 + Y0) - i (Y1 - J0))``. It is evaluated as
    ``1 / (1 + i H0/H1)`` which is well conditioned for all ``k > 0``.
    Limits: ``C(0) = 1`` (quasi-steady), ``C(k) -> 1/2`` as ``k -> inf``.

    References
    ----------
    Theodorsen (1935), NACA Report 496; Bisplinghoff, Ashley & Halfman (1955), section 5-6
    (tabulated F and G).
    """
    karr = _reduced_frequency(k)
    ka = np.abs(karr)
    out = np.empty(ka.shape, dtype=complex)
    small = ka < _K_TINY
    large = np.isinf(ka)
    mid = ~(small | large)
    out[small] = 1.0
    out[large] = 0.5
    if np.any(mid):
        km = ka[mid]
        ratio = hankel2(0, km) / hankel2(1, km)
        out[mid] = 1.0 / (1.0 + 1j * ratio)
    out = np.where(karr < 0, np.conj(out), out)
    return out[()] if out.ndim == 0 else out


def theodorsen_scalar(k: float) -> complex:
    """:func:`theodorsen` for one real ``k >= 0`` [-], without the array handling.

    The inner loop of the p-k iteration (:mod:`bridgeflap.model.stability.pk_kernel`): the same
    ratio ``1 / (1 + i H0/H1)`` with the Hankel functions written as ``H_n = J_n - i Y_n`` (the four
    real Bessel functions take a fraction of the time of two complex ``hankel2`` calls on a
    scalar; above ``k = 10``, where those lose relative accuracy near their zeros, ``hankel2``
    as in :func:`theodorsen`), and the same limits (``C = 1`` below ``1e-200``, ``1/2`` at
    ``inf``); equal to :func:`theodorsen` to round-off (``tests/test_pk_fast.py``). No input
    checks: the caller's ``k = |Im p| b / U`` is real and non-negative by construction.
    """
    if k < _K_TINY:
        return 1.0 + 0.0j
    if k > _K_BESSEL:
        return 0.5 + 0.0j if k == np.inf else complex(1.0 / (1.0 + 1j * (hankel2(0, k)
                                                                         / hankel2(1, k))))
    return 1.0 / (1.0 + 1j * (complex(j0(k), -y0(k)) / complex(j1(k), -y1(k))))


def sears(k: ArrayLike) -> np.complex128 | NDArray[np.complex128]:
    r"""Sears function S(k) for a sinusoidal vertical gust, referenced to mid-chord, exact.

    Parameters
    ----------
    k : array_like
        Reduced frequency ``k = omega b / U`` [-], real.

    Returns
    -------
    complex or ndarray of complex
        ``S(k)`` [-], same shape as ``k``; ``S(0) = 1`` and ``S(k) -> 0`` as ``k -> inf``.

    Notes
    -----
    With the gust phase referred to mid-chord (Bisplinghoff form)

    .. math:: S(k) = [J_0(k) - i J_1(k)]\,C(k) + i J_1(k).

    Referring the gust to the leading edge multiplies ``S`` by ``exp(-i k)``, which changes
    the phase but not ``|S|``, so the buffeting admittance ``|S|^2`` is unaffected.

    References
    ----------
    Sears (1941), J. Aeronaut. Sci. 8(3); Bisplinghoff, Ashley & Halfman (1955), section 5-7.
    """
    karr = _reduced_frequency(k)
    ka = np.abs(karr)
    finite = np.isfinite(ka)
    kf = np.where(finite, ka, 0.0)
    c = np.asarray(theodorsen(kf))
    out = (j0(kf) - 1j * j1(kf)) * c + 1j * j1(kf)
    out = np.where(finite, out, 0.0 + 0.0j)
    out = np.where(karr < 0, np.conj(out), out)
    return out[()] if out.ndim == 0 else out


def sears_admittance_sq(k: ArrayLike) -> np.float64 | NDArray[np.float64]:
    """Squared modulus of the exact Sears function, ``|S(k)|^2`` [-].

    Parameters
    ----------
    k : array_like
        Reduced frequency ``k = omega b / U`` [-].

    Returns
    -------
    float or ndarray
        ``|S(k)|^2`` [-], 1 at ``k = 0``.

    References
    ----------
    Sears (1941); the paper Eq. (14) (``chi_Lw = chi_Mw = S``).
    """
    return np.abs(sears(k)) ** 2


def liepmann_admittance_sq(k: ArrayLike) -> np.float64 | NDArray[np.float64]:
    """Liepmann's approximation of the Sears admittance, ``|chi|^2 = 1 / (1 + 2 pi k)`` [-].

    Parameters
    ----------
    k : array_like
        Reduced frequency ``k = omega b / U`` [-] (``|k|`` is used).

    Returns
    -------
    float or ndarray
        ``1 / (1 + 2 pi |k|)`` [-]. Equivalent to ``1 / (1 + 2 pi^2 n B / U)`` with
        ``B = 2 b`` and ``n`` in Hz.

    Notes
    -----
    It underestimates the exact ``|S|^2`` by up to about 14.5 % (worst near ``k = 0.24``),
    docs/humber_data.md#gust-admittance.

    References
    ----------
    Liepmann (1952), J. Aeronaut. Sci. 19(12).
    """
    ka = np.abs(_reduced_frequency(k))
    out = 1.0 / (1.0 + 2.0 * np.pi * ka)
    return out[()] if out.ndim == 0 else out


def unit_admittance_sq(k: ArrayLike) -> np.float64 | NDArray[np.float64]:
    """Quasi-steady admittance, ``|chi|^2 = 1`` at every reduced frequency [-].

    Parameters
    ----------
    k : array_like
        Reduced frequency ``k = omega b / U`` [-] (only its shape is used).

    Returns
    -------
    float or ndarray
        Ones with the shape of ``k`` [-].
    """
    out = np.ones_like(_reduced_frequency(k))
    return out[()] if out.ndim == 0 else out


def t_functions(c: ArrayLike, a: float = 0.0) -> dict[str, np.float64 | NDArray[np.float64]]:
    """Theodorsen's T-functions T1..T14 for a trailing-edge flap hinged at ``x = c b``.

    Parameters
    ----------
    c : array_like
        Hinge position in semichords from mid-chord [-], ``-1 <= c <= 1``
        (``c = -1`` leading edge, ``c = +1`` trailing edge).
    a : float, optional
        Elastic-axis position in semichords from mid-chord [-]; enters only ``T9`` and
        ``T13``, ``T14``. Default 0 (mid-chord, the package convention).

    Returns
    -------
    dict of str to float or ndarray
        Keys ``"T1"`` ... ``"T14"`` [-], each with the shape of ``c``.

    Notes
    -----
    With ``mu = arccos c`` and ``s = sqrt(1 - c^2)``
    (docs/humber_data.md#flap-loads-and-t-functions):

    * ``T1 = -s (2 + c^2)/3 + c mu``
    * ``T2 = c (1 - c^2) - s (1 + c^2) mu + c mu^2``
    * ``T3 = -(1/8 + c^2) mu^2 + c s mu (7 + 2 c^2)/4 - (1 - c^2)(5 c^2 + 4)/8``
    * ``T4 = -mu + c s``
    * ``T5 = -(1 - c^2) - mu^2 + 2 c s mu``
    * ``T6 = T2``
    * ``T7 = -(1/8 + c^2) mu + c s (7 + 2 c^2)/8``
    * ``T8 = -s (2 c^2 + 1)/3 + c mu``
    * ``T9 = (s^3/3 + a T4)/2``
    * ``T10 = s + mu``
    * ``T11 = mu (1 - 2 c) + s (2 - c)``
    * ``T12 = s (2 + c) - mu (2 c + 1)``
    * ``T13 = (-T7 - (c - a) T1)/2``
    * ``T14 = 1/16 + a c/2``

    Limits used as unit tests: at ``c = +1`` every T except ``T14`` vanishes (``T14``
    is a hinge-moment constant, ``1/16`` for ``a = 0``); at ``c = -1`` the flap terms reduce to
    the pitch terms for ``a = -1``.

    References
    ----------
    Theodorsen (1935), NACA Report 496, Table of T-functions; Theodorsen & Garrick (1942),
    NACA Report 736.
    """
    carr = np.asarray(c, dtype=float)
    if np.any(~np.isfinite(carr)) or np.any(np.abs(carr) > 1.0):
        raise BridgeflapInputError("hinge_c", "must lie in [-1, 1] semichords from mid-chord")
    mu = np.arccos(carr)
    s = np.sqrt(np.clip(1.0 - carr**2, 0.0, None))
    c2 = carr**2
    t = {}
    t["T1"] = -s * (2.0 + c2) / 3.0 + carr * mu
    t["T2"] = carr * (1.0 - c2) - s * (1.0 + c2) * mu + carr * mu**2
    t["T3"] = (
        -(0.125 + c2) * mu**2
        + 0.25 * carr * s * mu * (7.0 + 2.0 * c2)
        - 0.125 * (1.0 - c2) * (5.0 * c2 + 4.0)
    )
    t["T4"] = -mu + carr * s
    t["T5"] = -(1.0 - c2) - mu**2 + 2.0 * carr * s * mu
    t["T6"] = t["T2"]
    t["T7"] = -(0.125 + c2) * mu + 0.125 * carr * s * (7.0 + 2.0 * c2)
    t["T8"] = -s * (2.0 * c2 + 1.0) / 3.0 + carr * mu
    t["T9"] = 0.5 * (s**3 / 3.0 + a * t["T4"])
    t["T10"] = s + mu
    t["T11"] = mu * (1.0 - 2.0 * carr) + s * (2.0 - carr)
    t["T12"] = s * (2.0 + carr) - mu * (2.0 * carr + 1.0)
    t["T13"] = 0.5 * (-t["T7"] - (carr - a) * t["T1"])
    t["T14"] = 0.0625 + 0.5 * a * carr
    order = [f"T{i}" for i in range(1, 15)]
    return {key: (np.asarray(t[key])[()] if carr.ndim == 0 else t[key]) for key in order}


class FlapSteadyCoefficients(NamedTuple):
    """Steady aerodynamic derivatives of a flap (see :func:`flap_steady_coefficients`)."""

    lift_slope: float
    """dC_L/d(angle) [1/rad], lift positive up, C_L on ``q 2b``."""
    moment_slope_mid: float
    """dC_M/d(angle) [1/rad], nose-up moment about mid-chord, C_M on ``q (2b)^2``."""


def flap_steady_coefficients(hinge_c: float, edge: str = "trailing") -> FlapSteadyCoefficients:
    """Steady lift and mid-chord moment derivatives of a trailing- or leading-edge flap.

    Parameters
    ----------
    hinge_c : float
        Hinge position in semichords from mid-chord [-], ``-1 <= hinge_c <= 1``. A 20 % chord
        TE flap has ``c = 0.6``, a 20 % chord LE flap ``e = -0.6``. The end points are the
        degenerate flaps: no flap, or the whole plate (a rigid pitch).
    edge : {"trailing", "leading"}
        Which flap. The TE-flap angle ``beta`` is TE-down positive, the LE-flap angle
        ``delta`` LE-up positive; both have the rotational sense of nose-up ``alpha``.

    Returns
    -------
    FlapSteadyCoefficients
        ``lift_slope`` [1/rad] (upward lift on ``q 2b``) and ``moment_slope_mid`` [1/rad]
        (nose-up, about mid-chord, on ``q (2b)^2``).

    Notes
    -----
    Setting ``k = 0`` (``C = 1``) and ``a = 0`` in the TR-496 loads of
    docs/humber_data.md#flap-loads-and-t-functions:

    * TE flap: ``L_up = 2 rho U^2 b T10 beta`` and
      ``M_mid = rho U^2 b^2 [-(T4 + T10) + T10] beta = -rho U^2 b^2 T4 beta``, so
      ``dC_L/dbeta = 2 T10`` and ``dC_M,mid/dbeta = -T4 / 2``.
    * LE flap (exact decomposition in linear theory): a rigid pitch ``delta`` of the whole
      chord (steady ``dC_L = 2 pi``, ``dC_M,mid = pi/2``, lift at the quarter chord) plus a
      TE flap ``beta = -delta`` hinged at ``c = e``. Hence
      ``dC_L/ddelta = 2 pi - 2 T10(e) = 2 (theta_h - sin theta_h)`` with
      ``cos theta_h = -e``, and ``dC_M,mid/ddelta = pi/2 + T4(e)/2``.

    References
    ----------
    Theodorsen (1935), NACA Report 496; Abbott & von Doenhoff, *Theory of Wing Sections*
    (1959) (steady thin-aerofoil flap theory);
    docs/humber_data.md#flap-loads-and-t-functions check table.
    """
    c = float(hinge_c)
    if edge == "trailing":
        t = t_functions(c)
        return FlapSteadyCoefficients(float(2.0 * t["T10"]), float(-0.5 * t["T4"]))
    if edge == "leading":
        t = t_functions(c)
        lift = 2.0 * np.pi - 2.0 * t["T10"]
        moment = 0.5 * np.pi + 0.5 * t["T4"]
        return FlapSteadyCoefficients(float(lift), float(moment))
    raise BridgeflapInputError("edge", f"must be 'trailing' or 'leading', got {edge!r}")
