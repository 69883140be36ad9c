r"""Rational (lag-form) approximations of Theodorsen's function for state-space models.

Conventions (``k = omega b / U``, ``s_bar = s b / U``, ``b`` the half-chord) are those of
:mod:`model`. The approximation is the lag form

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
.. [3] T. Theodorsen, NACA Report 496, 1935 (the exact ``C(k)``; :mod:`model.theodorsen`).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import least_squares, minimize_scalar

from model.errors import BridgeflapInputError
from model.theodorsen import theodorsen

__all__ = ["RFA_NAMES", "RationalApprox", "fit_theodorsen", "get_rfa", "jones"]

RFA_NAMES: tuple[str, ...] = ("rfa4", "jones")
"""Names accepted by :func:`get_rfa`."""

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
            ``k_at_max_error`` [-].
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
        }


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


def fit_theodorsen(n_lags: int = 4, k_max: float = 3.0) -> RationalApprox:
    """Fit the lag form to the exact Theodorsen function by least squares.

    Parameters
    ----------
    n_lags : int, optional
        Number of lag terms [-], >= 1. Default 4.
    k_max : float, optional
        Upper reduced frequency of the fit [-]. Default 3.

    Returns
    -------
    RationalApprox
        Fitted approximation, ``name = f"rfa{n_lags}"``, poles sorted ascending.

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

    References
    ----------
    Roger (1977), AGARD CP-228; Golub & Pereyra (1973), SIAM J. Numer. Anal. 10(2)
    (variable projection); docs/methods.md#rational-approximation.
    """
    if int(n_lags) != n_lags or n_lags < 1:
        raise BridgeflapInputError("n_lags", f"must be an integer >= 1, got {n_lags!r}")
    if not (np.isfinite(k_max) and k_max > _K_MIN_FIT):
        raise BridgeflapInputError("k_max", f"must be finite and > {_K_MIN_FIT}, got {k_max!r}")
    return _fit_theodorsen_cached(int(n_lags), float(k_max))


@functools.lru_cache(maxsize=16)
def _fit_theodorsen_cached(n_lags: int, k_max: float) -> RationalApprox:
    """Fit for normalised arguments; cached worker of :func:`fit_theodorsen`."""
    k = np.geomspace(_K_MIN_FIT, k_max, _N_FIT)
    s_bar = 1j * k
    target = 1.0 - np.asarray(theodorsen(k))  # sum_j A_j phi_j(ik) should equal 1 - C(k)

    if n_lags == 4:
        start = _REF4_POLES
    elif n_lags == 2:
        start = _JONES_POLES
    else:
        start = np.geomspace(0.01, 1.0, n_lags)

    def residual(log_poles: NDArray[np.float64]) -> NDArray[np.float64]:
        basis = _lag_basis(s_bar, np.exp(log_poles))
        gains = _constrained_gains(basis, target, 0.5)
        err = basis @ gains - target
        return np.concatenate([err.real, err.imag])

    sol = least_squares(residual, np.log(start), xtol=1e-12, ftol=1e-12, gtol=1e-12)
    poles = np.exp(sol.x)
    order = np.argsort(poles)
    poles = poles[order]
    gains = _constrained_gains(_lag_basis(s_bar, poles), target, 0.5)
    err, _ = _max_error(gains, poles, k_max)
    return RationalApprox(gains, poles, f"rfa{n_lags}", err, k_max)


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
    name : {"rfa4", "jones"}
        ``"rfa4"``: the default 4-lag least-squares fit (:func:`fit_theodorsen`);
        ``"jones"``: R. T. Jones's 2-lag approximation (:func:`jones`).

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
    raise BridgeflapInputError(
        "rfa", f"unknown approximation {name!r}; expected one of {RFA_NAMES}"
    )
