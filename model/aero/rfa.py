r"""Rational (lag-form) approximations of Theodorsen's function for state-space models.

Conventions (``k = omega b / U``, ``s_bar = s b / U``, ``b`` the half-chord) are those of
:mod:`bridgeflap.model`. The approximation is the lag form

.. math:: C(\bar s) \approx 1 - \sum_{j=1}^{n} A_j \frac{\bar s}{\bar s + \beta_j},

so that ``C(0) = 1`` holds identically and ``C(inf) = 1 - sum_j A_j``. Each lag becomes one
aerodynamic state per downwash signal, ``y_j' = (beta_j U / b) (Q - y_j)`` with
``C Q = Q/2 + sum_j A_j y_j`` when ``sum_j A_j = 1/2`` (docs/methods.md#rational-approximation).

References
----------
.. [1] R. T. Jones, "The unsteady lift of a wing of finite aspect ratio", NACA Report 681,
   1940 (the two-lag coefficients 0.165/0.0455 and 0.335/0.3).
.. [2] K. L. Roger, "Airplane math modeling methods for active control design", AGARD
   CP-228, 1977 (least-squares rational function approximation with lag terms).
.. [3] T. Theodorsen, NACA Report 496, 1935 (the exact ``C(k)``;
:mod:`bridgeflap.model.aero.theodorsen`).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import least_squares, minimize_scalar

from bridgeflap.model.aero.theodorsen import theodorsen
from bridgeflap.model.errors import BridgeflapInputError

__all__ = ["BAND_WEIGHT", "FLUTTER_BAND_K", "RFA_NAMES", "RationalApprox", "band_error",
           "fit_theodorsen", "get_rfa", "jones"]

RFA_NAMES: tuple[str, ...] = ("rfa4", "jones", "rfa4-band")
"""Names accepted by :func:`get_rfa`."""

FLUTTER_BAND_K: tuple[float, float] = (0.05, 0.5)
"""Reduced-frequency band ``k = omega b / U`` [-] of bridge flutter that ``"rfa4-band"`` weights:
the 2-D sections, IABSE 1.1a / 2a and Humber flutter at ``k`` 0.21-0.32, and the other structural
modes of a bridge at its flutter speed lie between about 0.05 (first vertical) and 0.5."""

BAND_WEIGHT: float = 10.0
"""Least-squares weight [-] of the fitting points inside :data:`FLUTTER_BAND_K` for
``"rfa4-band"`` (1 outside): the largest round weight whose fit keeps max ``|C_fit - C|`` on
``0 < k <= 3`` at the 3.0e-3 of a 4-lag fit (docs/methods.md#rational-approximation) while the
error inside the band falls from 1.1e-3 to 5e-4 (``runs/rfa_fit/run.py``)."""

# Reference 4-lag fit of docs/humber_data.md#lift-deficiency-approximations (max |error| 0.0032 on 0
# < k <= 3): starting point.
_REF4_POLES = np.array([0.013122, 0.079132, 0.246519, 0.750758])
_JONES_GAINS = np.array([0.165, 0.335])
_JONES_POLES = np.array([0.0455, 0.3])

_K_MIN_FIT = 1.0e-3  # lowest reduced frequency of the fitting grid [-]
_N_FIT = 400  # fitting points, log-spaced on [_K_MIN_FIT, k_max]
_K_MIN_CHECK = 1.0e-6  # error check grid: below it |C - 1| and |C_fit - 1| are both < 1e-4
_N_CHECK = 8000


def _lag_basis(s_bar: NDArray[np.complex128], poles: NDArray[np.float64]) -> NDArray:
    """Matrix ``s_bar / (s_bar + beta_j)``, shape ``s_bar.shape + (n_lags,)``."""
    s = s_bar[..., None]
    return s / (s + poles)


def _max_error(gains: NDArray, poles: NDArray, k_max: float) -> tuple[float, float]:
    """Max |C_fit(ik) - C(ik)| on 0 < k <= k_max and the k where it occurs (refined)."""

    def err(k: NDArray[np.float64]) -> NDArray[np.float64]:
        fit = 1.0 - _lag_basis(1j * k, poles) @ gains
        return np.abs(fit - theodorsen(k))

    kk = np.geomspace(min(_K_MIN_CHECK, k_max), k_max, _N_CHECK)
    e = err(kk)
    i = int(np.argmax(e))
    lo, hi = kk[max(i - 1, 0)], kk[min(i + 1, kk.size - 1)]
    if hi > lo:
        res = minimize_scalar(
            lambda x: -float(err(np.array([x]))[0]),
            bounds=(lo, hi),
            method="bounded",
            options={"xatol": 1e-10 * hi},
        )
        if -res.fun > e[i]:
            return float(-res.fun), float(res.x)
    return float(e[i]), float(kk[i])


@dataclass(frozen=True, eq=False)
class RationalApprox:
    """Lag-form rational approximation ``C(s_bar) = 1 - sum_j A_j s_bar / (s_bar + beta_j)``.

    Parameters
    ----------
    gains : numpy.ndarray
        Lag gains ``A_j`` [-], shape ``(n_lags,)``.
    poles : numpy.ndarray
        Lag poles ``beta_j`` [-] in aerodynamic time (physical pole ``-beta_j U / b``
        [1/s]), shape ``(n_lags,)``, all strictly positive.
    name : str
        Label of the approximation (e.g. ``"rfa4"``, ``"jones"``).
    max_error : float
        Max ``|C_fit(ik) - C(ik)|`` [-] on ``0 < k <= k_max``.
    k_max : float
        Upper end of the reduced-frequency range of fit and error check [-].
    fit_band : tuple of float or None, optional
        ``(k_lo, k_hi)`` [-] of the least-squares band weighted by ``band_weight`` (``None``:
        an unweighted fit or a hand-chosen approximation).
    band_weight : float, optional
        Weight [-] of the fitting points inside ``fit_band`` (1 elsewhere). Default 1.

    Notes
    -----
    The arrays are stored as read-only float copies, so a cached instance cannot be altered.
    Instances compare by identity (``eq=False``): numpy arrays have no scalar equality.
    """

    gains: np.ndarray
    poles: np.ndarray
    name: str
    max_error: float
    k_max: float
    fit_band: tuple[float, float] | None = None
    band_weight: float = 1.0

    def __post_init__(self) -> None:
        """Validate and freeze the coefficient arrays."""
        gains = np.array(self.gains, dtype=float).reshape(-1)
        poles = np.array(self.poles, dtype=float).reshape(-1)
        if gains.shape != poles.shape or gains.size == 0:
            raise BridgeflapInputError("gains", "gains and poles must be 1-D of equal length >= 1")
        if not (np.all(np.isfinite(gains)) and np.all(np.isfinite(poles))):
            raise BridgeflapInputError("poles", "gains and poles must be finite")
        if np.any(poles <= 0.0):
            raise BridgeflapInputError("poles", "all lag poles beta_j must be > 0 (stable lags)")
        if not self.k_max > 0.0:
            raise BridgeflapInputError("k_max", "must be > 0")
        band = None if self.fit_band is None else _check_band(self.fit_band, self.k_max)
        if not (np.isfinite(self.band_weight) and self.band_weight > 0.0):
            raise BridgeflapInputError("band_weight", f"must be finite and > 0, got "
                                       f"{self.band_weight!r}")
        object.__setattr__(self, "fit_band", band)
        object.__setattr__(self, "band_weight", float(self.band_weight))
        gains.setflags(write=False)
        poles.setflags(write=False)
        object.__setattr__(self, "gains", gains)
        object.__setattr__(self, "poles", poles)
        object.__setattr__(self, "max_error", float(self.max_error))
        object.__setattr__(self, "k_max", float(self.k_max))

    @property
    def n_lags(self) -> int:
        """Number of lag terms (aerodynamic states per downwash signal)."""
        return int(self.gains.size)

    def evaluate_s(self, s_bar: ArrayLike) -> np.complex128 | NDArray[np.complex128]:
        """Evaluate the approximation at the non-dimensional Laplace variable.

        Parameters
        ----------
        s_bar : array_like
            ``s_bar = s b / U`` [-], real or complex, any shape.

        Returns
        -------
        complex or ndarray of complex
            ``1 - sum_j A_j s_bar / (s_bar + beta_j)`` [-], shape of ``s_bar``.
        """
        s = np.asarray(s_bar, dtype=complex)
        out = 1.0 - _lag_basis(s, self.poles) @ self.gains
        return out[()] if out.ndim == 0 else out

    def evaluate(self, k: ArrayLike) -> np.complex128 | NDArray[np.complex128]:
        """The approximation of ``C(k)`` [-] on the imaginary axis ``s_bar = i k``.

        ``k = omega b / U`` [-] is real (array_like); the result has the shape of ``k``.
        """
        return self.evaluate_s(1j * np.asarray(k, dtype=float))

    def report(self) -> dict[str, object]:
        """Coefficients and accuracy of the approximation.

        Returns
        -------
        dict
            ``name``, ``n_lags``, ``gains`` and ``poles`` (lists), ``sum_gains`` (``1 - C(inf)``),
            ``k_max`` [-], ``max_error`` [-] (max ``|C_fit - C|`` on ``0 < k <= k_max``,
            recomputed on a dense log grid with local refinement) and
            ``k_at_max_error`` [-]; ``fit_band_k`` (``[k_lo, k_hi]`` or ``None``),
            ``fit_band_weight`` [-] and ``max_error_in_flutter_band`` [-] (max ``|C_fit - C|``
            on :data:`FLUTTER_BAND_K`, whatever the fit's own band).
        """
        err, k_at = _max_error(self.gains, self.poles, self.k_max)
        return {
            "name": self.name,
            "n_lags": self.n_lags,
            "gains": self.gains.tolist(),
            "poles": self.poles.tolist(),
            "sum_gains": float(self.gains.sum()),
            "k_max": self.k_max,
            "max_error": err,
            "k_at_max_error": k_at,
            "fit_band_k": None if self.fit_band is None else list(self.fit_band),
            "fit_band_weight": self.band_weight,
            "max_error_in_flutter_band": band_error(self, FLUTTER_BAND_K),
        }


def band_error(approx: RationalApprox, band: tuple[float, float]) -> float:
    """Max ``|C_fit(ik) - C(ik)|`` [-] of ``approx`` on ``band[0] <= k <= band[1]`` [-].

    Dense log grid (4000 points; the error curve's ripples span a fifth of a decade or more, so
    the grid's maximum is within 1e-7 of the refined one).
    """
    k = np.geomspace(float(band[0]), float(band[1]), 4000)
    return float(np.max(np.abs(approx.evaluate(k) - theodorsen(k))))


def _check_band(band, k_max: float) -> tuple[float, float]:
    """Validated ``(k_lo, k_hi)`` with ``_K_MIN_FIT <= k_lo < k_hi <= k_max``."""
    try:
        lo, hi = (float(v) for v in band)
    except (TypeError, ValueError):
        raise BridgeflapInputError("band", f"must be two numbers (k_lo, k_hi), got "
                                   f"{band!r}") from None
    if not (np.isfinite(lo) and np.isfinite(hi) and _K_MIN_FIT <= lo < hi <= k_max):
        raise BridgeflapInputError("band", f"needs {_K_MIN_FIT} <= k_lo < k_hi <= k_max = "
                                   f"{k_max}, got ({lo}, {hi})")
    return lo, hi


def _constrained_gains(
    basis: NDArray[np.complex128], target: NDArray[np.complex128], total: float
) -> NDArray[np.float64]:
    """Real LSQ gains minimising ``|basis @ A - target|`` subject to ``sum(A) = total``.

    The last gain is eliminated, ``A_n = total - sum_{j<n} A_j``, and the remaining ones come
    from an ordinary least-squares problem on the stacked real and imaginary parts.
    """
    n = basis.shape[1]
    if n == 1:
        return np.array([total])
    m = basis[:, :-1] - basis[:, -1:]
    rhs = target - total * basis[:, -1]
    m_real = np.vstack([m.real, m.imag])
    rhs_real = np.concatenate([rhs.real, rhs.imag])
    head, *_ = np.linalg.lstsq(m_real, rhs_real, rcond=None)
    return np.concatenate([head, [total - head.sum()]])


def fit_theodorsen(n_lags: int = 4, k_max: float = 3.0, band: tuple[float, float] | None = None,
                   band_weight: float = 1.0) -> RationalApprox:
    """Fit the lag form to the exact Theodorsen function by least squares.

    Parameters
    ----------
    n_lags : int, optional
        Number of lag terms [-], >= 1. Default 4.
    k_max : float, optional
        Upper reduced frequency of the fit [-]. Default 3.
    band : (float, float), optional
        ``(k_lo, k_hi)`` [-]: the fitting points in this band get weight ``band_weight``, the
        others 1. Default ``None``: the unweighted fit (the package default ``"rfa4"``).
    band_weight : float, optional
        Weight [-] of the band's points, > 0. Default 1. Ignored without ``band``.

    Returns
    -------
    RationalApprox
        Fitted approximation, poles sorted ascending; ``name = f"rfa{n_lags}"`` unweighted,
        ``f"rfa{n_lags}-band"`` on :data:`FLUTTER_BAND_K` with :data:`BAND_WEIGHT`, otherwise
        ``f"rfa{n_lags}-band[k_lo,k_hi]x{band_weight}"``.

    Notes
    -----
    * ``C(0) = 1`` holds by construction of the lag form; ``C(inf) = 1/2`` is enforced as the
      linear equality ``sum_j A_j = 1/2`` (the last gain is eliminated).
    * Variable projection: the poles are optimised as ``log beta_j`` (hence strictly positive)
      by ``scipy.optimize.least_squares``; for given poles the gains solve the constrained
      linear least-squares problem exactly.
    * Residual: ``C_fit(ik) - C(ik)`` (real and imaginary parts) at 400 points log-spaced on
      ``[1e-3, k_max]``, unit weight per point, i.e. a uniform weight per unit ``log k``
      (weight ``1/k`` per unit ``k``), which keeps the low-``k`` region that governs bridge
      flutter (``k`` of order 0.05-0.5) as well resolved as the high-``k`` end.
    * Starting poles: the docs/humber_data.md#lift-deficiency-approximations reference fit for 4
      lags, R. T. Jones's poles for 2 lags, otherwise ``geomspace(0.01, 1, n_lags)``. The fit is
      deterministic and cached per ``(n_lags, k_max)`` for the life of the process.
    * For ``n_lags = 4``, ``k_max = 3`` the result has max ``|error|`` about 1.5e-3, better
      than the 3.2e-3 of the reference fit (which is the starting point).
    * That unweighted fit spreads its equal-ripple error (1.1-1.5e-3) over the 3.5 decades
      ``1e-3 <= k <= 3``; the flutter band ``0.05-0.5`` holds a fifth of the points, and the
      fit reads 0.06-0.13 % off the exact flutter speed of the 2-D cases
      (``runs/rfa_fit/run.py``). A band weight trades error outside the band (mostly at
      ``k < 0.05``, where ``C`` is within 3 % of 1) for error inside it: with ``band =
      FLUTTER_BAND_K`` and ``band_weight = BAND_WEIGHT`` the band's max ``|error|`` is about
      5e-4 and the whole range's 3.0e-3; the weighted fit starts from the unweighted one's
      poles (a continuation, deterministic).

    References
    ----------
    Roger (1977), AGARD CP-228; Golub & Pereyra (1973), SIAM J. Numer. Anal. 10(2)
    (variable projection); docs/methods.md#rational-approximation.
    """
    if int(n_lags) != n_lags or n_lags < 1:
        raise BridgeflapInputError("n_lags", f"must be an integer >= 1, got {n_lags!r}")
    if not (np.isfinite(k_max) and k_max > _K_MIN_FIT):
        raise BridgeflapInputError("k_max", f"must be finite and > {_K_MIN_FIT}, got {k_max!r}")
    if band is None:
        return _fit_theodorsen_cached(int(n_lags), float(k_max))
    lo, hi = _check_band(band, float(k_max))
    if not (isinstance(band_weight, int | float) and np.isfinite(band_weight)
            and band_weight > 0):
        raise BridgeflapInputError("band_weight", f"must be finite and > 0, got "
                                   f"{band_weight!r}")
    return _fit_band_cached(int(n_lags), float(k_max), lo, hi, float(band_weight))


@functools.lru_cache(maxsize=16)
def _fit_theodorsen_cached(n_lags: int, k_max: float) -> RationalApprox:
    """Fit for normalised arguments; cached worker of :func:`fit_theodorsen`."""
    if n_lags == 4:
        start = _REF4_POLES
    elif n_lags == 2:
        start = _JONES_POLES
    else:
        start = np.geomspace(0.01, 1.0, n_lags)
    gains, poles = _fit(n_lags, k_max, start, None)
    err, _ = _max_error(gains, poles, k_max)
    return RationalApprox(gains, poles, f"rfa{n_lags}", err, k_max)


@functools.lru_cache(maxsize=16)
def _fit_band_cached(n_lags: int, k_max: float, lo: float, hi: float,
                     weight: float) -> RationalApprox:
    """Band-weighted fit, started from the unweighted one's poles; worker of
    :func:`fit_theodorsen`."""
    start = _fit_theodorsen_cached(n_lags, k_max).poles
    k = np.geomspace(_K_MIN_FIT, k_max, _N_FIT)
    w = np.where((k >= lo) & (k <= hi), weight, 1.0)
    gains, poles = _fit(n_lags, k_max, start, w)
    err, _ = _max_error(gains, poles, k_max)
    if (lo, hi) == FLUTTER_BAND_K and weight == BAND_WEIGHT:
        name = f"rfa{n_lags}-band"
    else:
        name = f"rfa{n_lags}-band[{lo:g},{hi:g}]x{weight:g}"
    return RationalApprox(gains, poles, name, err, k_max, (lo, hi), weight)


def _fit(n_lags: int, k_max: float, start: NDArray, w: NDArray | None) -> tuple[NDArray, NDArray]:
    """Variable-projection fit on the log grid: ``(gains, poles)``, poles ascending.

    ``w``: weight per fitting point (``None``: unit weights; that path is the original fit,
    operation for operation, so the default ``"rfa4"`` is unchanged to the last bit).
    """
    k = np.geomspace(_K_MIN_FIT, k_max, _N_FIT)
    s_bar = 1j * k
    target = 1.0 - np.asarray(theodorsen(k))  # sum_j A_j phi_j(ik) should equal 1 - C(k)

    def gains_of(basis: NDArray[np.complex128]) -> NDArray[np.float64]:
        if w is None:
            return _constrained_gains(basis, target, 0.5)
        return _constrained_gains(basis * w[:, None], target * w, 0.5)

    def residual(log_poles: NDArray[np.float64]) -> NDArray[np.float64]:
        basis = _lag_basis(s_bar, np.exp(log_poles))
        err = basis @ gains_of(basis) - target
        if w is not None:
            err = err * w
        return np.concatenate([err.real, err.imag])

    sol = least_squares(residual, np.log(start), xtol=1e-12, ftol=1e-12, gtol=1e-12)
    poles = np.exp(sol.x)
    order = np.argsort(poles)
    poles = poles[order]
    return gains_of(_lag_basis(s_bar, poles)), poles


@functools.lru_cache(maxsize=1)
def jones() -> RationalApprox:
    """R. T. Jones's two-lag approximation of Theodorsen's function.

    Returns
    -------
    RationalApprox
        ``A = [0.165, 0.335]``, ``beta = [0.0455, 0.3]`` (``sum A = 1/2``), ``k_max = 3``;
        max ``|error|`` about 0.0145 near ``k = 0.41``.

    References
    ----------
    R. T. Jones (1940), NACA Report 681; docs/humber_data.md#lift-deficiency-approximations (read
    in [CODE-1] theosears.m).
    """
    err, _ = _max_error(_JONES_GAINS, _JONES_POLES, 3.0)
    return RationalApprox(_JONES_GAINS, _JONES_POLES, "jones", err, 3.0)


def get_rfa(name: str) -> RationalApprox:
    """Return a named approximation of Theodorsen's function.

    Parameters
    ----------
    name : {"rfa4", "jones", "rfa4-band"}
        ``"rfa4"``: the default 4-lag least-squares fit (:func:`fit_theodorsen`);
        ``"jones"``: R. T. Jones's 2-lag approximation (:func:`jones`);
        ``"rfa4-band"``: the 4-lag fit weighted on the flutter band
        (``fit_theodorsen(4, 3.0, FLUTTER_BAND_K, BAND_WEIGHT)``; same model size, 0.03 % or
        less from exact Theodorsen on the 2-D flutter cases, against 0.13 % for ``"rfa4"``).

    Returns
    -------
    RationalApprox
        The (cached) approximation.

    Raises
    ------
    BridgeflapInputError
        If ``name`` is not one of :data:`RFA_NAMES`.
    """
    key = name.strip().lower() if isinstance(name, str) else name
    if key == "rfa4":
        return fit_theodorsen()
    if key == "jones":
        return jones()
    if key == "rfa4-band":
        return fit_theodorsen(4, 3.0, FLUTTER_BAND_K, BAND_WEIGHT)
    raise BridgeflapInputError(
        "rfa", f"unknown approximation {name!r}; expected one of {RFA_NAMES}"
    )
