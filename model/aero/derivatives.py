r"""Self-excited loads from Scanlan flutter derivatives: tables, flat plate, RFA, p-k.

Convention of this module ("Scanlan", Scanlan & Tomko 1971; Simiu & Scanlan 1996, with the
full chord ``B``): per unit span, for a deck moving harmonically at circular frequency
``omega`` in a mean wind ``U``, with the reduced frequency ``K = B omega / U``,

.. math::

    L &= \tfrac12\rho U^2 B\,[K H_1^* \dot h/U + K H_2^* B\dot\alpha/U + K^2 H_3^*\alpha
          + K^2 H_4^* h/B + K H_5^* \dot p/U + K^2 H_6^* p/B]\\
    M &= \tfrac12\rho U^2 B^2[K A_1^* \dot h/U + K A_2^* B\dot\alpha/U + K^2 A_3^*\alpha
          + K^2 A_4^* h/B + K A_5^* \dot p/U + K^2 A_6^* p/B]\\
    D &= \tfrac12\rho U^2 B\,[K P_1^* \dot p/U + K P_2^* B\dot\alpha/U + K^2 P_3^*\alpha
          + K^2 P_4^* p/B + K P_5^* \dot h/U + K^2 P_6^* h/B]

with ``h`` and ``L`` positive **up**, ``alpha`` and ``M`` positive **nose-up** (about
mid-chord) and the lateral ``p`` and drag ``D`` positive **downwind**. For harmonic motion
``K xdot / U = i K^2 x / B``, so the loads are ``F = 1/2 rho U^2 diag(B, B^2, B) Qn(K) x`` with
``x = (h/B, alpha, p/B)``, ``F = (L, M, D)`` and the non-dimensional complex matrix

.. math::

    Q_n(K) = K^2 \begin{pmatrix} H_4+iH_1 & H_3+iH_2 & H_6+iH_5\\
                                 A_4+iA_1 & A_3+iA_2 & A_6+iA_5\\
                                 P_6+iP_5 & P_3+iP_2 & P_4+iP_1 \end{pmatrix}.

The package's own coordinates (:mod:`bridgeflap.model`) have ``h`` (and the generalised lift)
positive **down**; :func:`bridgeflap.model.aeroelastic.derivative_system.strip_matrix` applies that
sign once.

Other conventions and the converters (:func:`convert_argument`, :func:`flip_heave_sign`,
:func:`polimi_to_scanlan`):

* **wawi / IABSE TG3.1** (``knutankv/wawi``, ``wawi/wind.py``: ``flatplate_ads``,
  ``K_from_ad``, ``C_from_ad``, ``element_aero_mats``): the same ``H_i^*, A_i^*, P_i^*``
  values, but as functions of the reduced velocity ``v = U / (B omega) = 1/K``; the load
  matrices act on the DOFs ``(y, z, theta_x)`` with ``theta_x = -alpha`` (so the ``h``-``alpha``
  couplings carry a factor ``-B``), ``z = h`` up, ``y = p`` downwind. The wawi flat plate drops
  the apparent-inertia moment (``A_3^*`` without ``pi/64``), i.e. ``added_inertia=False``.
* **reduced velocity in Hz**: ``V_r = U / (f B) = 2 pi / K`` (the PoliMi tables and most wind
  tunnel reports).
* **half-chord** (Theodorsen): ``k = omega b / U = K / 2``.
* **heave down** (e.g. Simiu & Scanlan's figures, this package's ``h``): ``H_2, H_3, A_1, A_4,
  H_5, H_6, P_5, P_6`` change sign, the others do not (:func:`flip_heave_sign`).
* **PoliMi** (Zasso 1996, used for the Storebaelt tables of IABSE step 1.1c): coefficients
  ``h_i^*, a_i^*, p_i^*`` tabulated against ``v`` and converted in wawi's test data as
  :func:`polimi_to_scanlan` states.

The flat plate (:class:`FlatPlateDerivatives`) is Theodorsen's thin aerofoil written in this
form (closed form from ``C(k) = F + iG`` at ``k = K/2``):
``H1 = -2 pi F/K``, ``H2 = pi/(2K) (1 + F + 4G/K)``, ``H3 = 2 pi/K (F/K - G/4)``,
``H4 = pi/2 (1 + 4G/K)``, ``A1 = -pi F/(2K)``, ``A2 = -pi/(8K) (1 - F - 4G/K)``,
``A3 = pi/(2K) (F/K - G/4) + kappa pi/64``, ``A4 = pi G/(2K)`` (``kappa = 1`` keeps the
apparent-inertia moment of the paper's Eq. (3), ``kappa = 0`` is Scanlan's and wawi's form). These
are identical to wawi's ``flatplate_ads`` for ``kappa = 0``.

**Rational function approximation** (:func:`fit_roger`, Roger 1977): with the non-dimensional
Laplace variable ``pbar = s B / U``

.. math:: Q_n(\bar p) \approx R_0 + R_1 \bar p + R_2 \bar p^2
          + \sum_{j=1}^{n} R_{j+2}\,\frac{\bar p}{\bar p + \gamma_j},

real ``R`` fitted by least squares on ``pbar = iK`` over the tabulated range, the lag poles
``gamma_j > 0`` chosen by a nonlinear least-squares search over ``log gamma`` (variable
projection: the ``R`` are solved linearly for each pole set), so every pole is stable by
construction (the search is bounded to ``K_min / 100 <= gamma <= 10 K_max``: a pole far above
the data range only duplicates the ``R1`` term). Each lag becomes ``n`` states
``x_j = pbar/(pbar + gamma_j) q``, i.e.
``x_j' = q' - (gamma_j U / B) x_j``, and the generalised loads
``1/2 rho U^2 [R0 q + R1 (B/U) q' + R2 (B/U)^2 q'' + sum_j R_{j+2} x_j]`` give the same
frequency-independent, speed-polynomial state space ``x' = (A0 + U A1 + U^2 A2) x`` as the
Theodorsen RFA (:mod:`bridgeflap.model.aeroelastic.statespace`), wrapped
(:mod:`bridgeflap.model.aeroelastic.derivative_system`) as an
:class:`~bridgeflap.model.aeroelastic.statespace.AeroelasticSystem` so that
:func:`bridgeflap.model.stability.sweeps.sweep` applies.

**Exact p-k** (``derivative_system(...).frozen()``): at a reduced frequency ``K`` the loads
are split into a stiffness ``1/2 rho U^2 Re Q`` and a damping ``1/2 rho U B Im Q / K`` (the
p-k form of wawi's ``itflutter_cont``); :func:`bridgeflap.model.stability.sweeps.pk_sweep` iterates
``K`` to consistency on the interpolated derivatives.

References
----------
.. [1] R. H. Scanlan, J. J. Tomko, "Airfoil and bridge deck flutter derivatives", J. Eng.
   Mech. Div. ASCE 97(6), 1717-1737, 1971.
.. [2] E. Simiu, R. H. Scanlan, *Wind Effects on Structures*, 3rd ed., Wiley, 1996, ch. 12.
.. [3] K. L. Roger, "Airplane math modeling methods for active control design", AGARD CP-228,
   1977.
.. [4] A. Zasso, "Flutter derivatives: advantages of a new representation convention",
   J. Wind Eng. Ind. Aerodyn. 60, 35-47, 1996 (the PoliMi form).
.. [5] K. A. Kvaale et al., wawi (NTNU, MIT licence), https://github.com/knutankv/wawi,
   ``wawi/wind.py`` and ``tests/test_IABSE_step11a.py``, ``tests/test_IABSE_step11c.py``
   (commit 395f0fd): conventions read there, no code copied.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import least_squares

from bridgeflap.model.aero.theodorsen import theodorsen
from bridgeflap.model.errors import BridgeflapInputError

__all__ = [
    "ARGUMENT_KINDS",
    "DERIVATIVE_NAMES",
    "FlatPlateDerivatives",
    "FlutterDerivatives",
    "PolimiDerivatives",
    "RogerFit",
    "TabulatedDerivatives",
    "convert_argument",
    "fit_roger",
    "flat_plate",
    "flip_heave_sign",
    "polimi_to_scanlan",
    "tabulated",
]

DERIVATIVE_NAMES: tuple[str, ...] = tuple(f"{f}{i}" for f in "HAP" for i in range(1, 7))
"""``H1..H6, A1..A6, P1..P6`` (Scanlan; 5 and 6 couple the lateral motion)."""

#: the DOF order of :func:`model.aeroelastic.derivative_system.strip_matrix`: heave, pitch, lateral
DOFS = ("h", "alpha", "p")

# entry (row, col) of Qn -> (real-part derivative, imaginary-part derivative)
_ENTRIES = {(0, 0): ("H4", "H1"), (0, 1): ("H3", "H2"), (0, 2): ("H6", "H5"),
            (1, 0): ("A4", "A1"), (1, 1): ("A3", "A2"), (1, 2): ("A6", "A5"),
            (2, 0): ("P6", "P5"), (2, 1): ("P3", "P2"), (2, 2): ("P4", "P1")}

ARGUMENT_KINDS: tuple[str, ...] = ("K", "v", "vred_hz", "k_half")
"""``K = B omega/U``; ``v = U/(B omega)`` (wawi); ``vred_hz = U/(f B)``; ``k_half = b omega/U``."""


def convert_argument(x: ArrayLike, source: str, target: str) -> NDArray[np.float64]:
    """Convert a reduced frequency / velocity between the kinds of :data:`ARGUMENT_KINDS`.

    ``K = 1/v = 2 pi / vred_hz = 2 k_half``.
    """
    for name, kind in (("source", source), ("target", target)):
        if kind not in ARGUMENT_KINDS:
            raise BridgeflapInputError(name, f"must be one of {ARGUMENT_KINDS}, got {kind!r}")
    a = np.asarray(x, dtype=float)
    to_K = {"K": lambda z: z, "v": lambda z: 1.0 / z, "vred_hz": lambda z: 2 * np.pi / z,
            "k_half": lambda z: 2.0 * z}
    from_K = {"K": lambda z: z, "v": lambda z: 1.0 / z, "vred_hz": lambda z: 2 * np.pi / z,
              "k_half": lambda z: 0.5 * z}
    with np.errstate(divide="ignore"):
        return from_K[target](to_K[source](a))


_HEAVE_ODD = ("H2", "H3", "A1", "A4", "H5", "H6", "P5", "P6")


def flip_heave_sign(values: dict) -> dict:
    """Derivatives for the opposite heave sign (``h`` and ``L`` up <-> down).

    ``H2, H3, A1, A4, H5, H6, P5, P6`` change sign (one of their two indices is the heave);
    ``H1, H4`` (heave-heave) and the others do not. The map is its own inverse.
    """
    return {k: (-np.asarray(v) if k in _HEAVE_ODD else np.asarray(v)) for k, v in values.items()}


def polimi_to_scanlan(v: ArrayLike, h: ArrayLike, a: ArrayLike, p: ArrayLike) -> dict:
    """Scanlan derivatives from PoliMi coefficients, as in the IABSE 1.1c data of wawi.

    Parameters
    ----------
    v : array (m,)
        Reduced velocity ``U / (B omega)`` [-].
    h, a, p : array (m, 6)
        PoliMi coefficients ``h_1..h_6``, ``a_1..a_6``, ``p_1..p_6`` at ``v``.

    Returns
    -------
    dict
        ``H_i = c_i h_i``, ``A_i = c_i a_i`` with ``c = (-v, -v, v^2, pi/2, -v, pi/2)`` and
        ``P1 = -v p5``, ``P2 = -v p2``, ``P3 = v^2 p3``, ``P4 = pi/2 p6``, ``P5 = -v p1``,
        ``P6 = pi/2 p4`` (the lateral PoliMi coefficients are ordered differently).

    Notes
    -----
    Read from the pickled conversion functions of ``tests/models/model_11c/AD_funs_SB_scanlan
    .pkl`` in ``knutankv/wawi`` with :mod:`pickletools` only (never unpickled): each function
    is ``fun_polimi[i](v) * (1 / C(v))`` with ``C1 = -1/v``, ``C3 = 1/v^2`` and the constant
    ``C2 = 2/pi`` (the float 0.6366197723675814 in the stream); the factors were confirmed
    against the ``HH_scanlan`` / ``AA_scanlan`` arrays stored in the same pickle (to their
    three printed digits). The pickle's own ``PP_scanlan`` array has ``P5 = -v p5``; its
    function (which wawi's test runs) has ``P5 = -v p1``: the function is followed here.
    """
    v = np.asarray(v, float)[:, None]
    h, a, p = (np.asarray(x, float) for x in (h, a, p))
    c = np.hstack([-v, -v, v * v, np.full_like(v, np.pi / 2), -v, np.full_like(v, np.pi / 2)])
    out = {}
    for fam, tab in (("H", h), ("A", a)):
        conv = c * tab
        for i in range(6):
            out[f"{fam}{i + 1}"] = conv[:, i]
    vv = v[:, 0]
    out.update({"P1": -vv * p[:, 4], "P2": -vv * p[:, 1], "P3": vv * vv * p[:, 2],
                "P4": np.pi / 2 * p[:, 5], "P5": -vv * p[:, 0], "P6": np.pi / 2 * p[:, 3]})
    return out


# --------------------------------------------------------------------------- sources


@dataclass(frozen=True)
class FlutterDerivatives:
    """Base of the derivative sources: Scanlan values at reduced frequencies ``K``.

    Attributes
    ----------
    chord_m : float
        ``B`` [m], the full chord of the normalisation.
    name, source : str
        Label and provenance.
    k_range : (float, float)
        Reduced-frequency range ``K`` [-] of the data (fit and error report range).
    lateral : bool
        Whether ``H5, H6, A5, A6, P1..P6`` are given (else they are zero).
    """

    chord_m: float
    name: str
    source: str
    k_range: tuple
    lateral: bool

    def values(self, K: ArrayLike) -> dict:  # pragma: no cover - abstract
        """All 18 derivatives at ``K`` (arrays of the shape of ``K``)."""
        raise NotImplementedError

    def matrix(self, K: ArrayLike, n_dof: int = 2) -> NDArray[np.complex128]:
        """``Qn(K)`` (module docstring), shape ``K.shape + (n_dof, n_dof)``."""
        Ka = np.asarray(K, float)
        vals = self.values(Ka)
        out = np.zeros(Ka.shape + (n_dof, n_dof), complex)
        for (r, c), (re, im) in _ENTRIES.items():
            if r < n_dof and c < n_dof:
                out[..., r, c] = Ka ** 2 * (vals[re] + 1j * vals[im])
        return out

    def table(self, K: ArrayLike) -> dict:
        """``{"K": ..., "H1": ...}`` lists for reports (JSON-ready)."""
        Ka = np.asarray(K, float)
        vals = self.values(Ka)
        return {"K": Ka.tolist(), **{k: np.asarray(vals[k]).tolist() for k in DERIVATIVE_NAMES}}


@dataclass(frozen=True)
class FlatPlateDerivatives(FlutterDerivatives):
    """Theodorsen's flat plate as flutter derivatives (closed form, module docstring).

    ``c_function`` evaluates ``C`` at the half-chord reduced frequency ``k`` (default the exact
    :func:`bridgeflap.model.aero.theodorsen.theodorsen`; a
    :class:`~bridgeflap.model.aero.rfa.RationalApprox` ``.evaluate`` gives the flat plate of the
    state-space RFA, which a Roger fit with poles ``2 beta_j`` reproduces exactly).
    """

    added_inertia: bool = False
    c_function: object = field(default=None, compare=False, repr=False)

    def values(self, K: ArrayLike) -> dict:
        Ka = np.asarray(K, float)
        if np.any(~np.isfinite(Ka)) or np.any(Ka <= 0):
            raise BridgeflapInputError("reduced_frequency", "K = B omega / U must be > 0")
        cf = self.c_function if self.c_function is not None else theodorsen
        C = np.asarray(cf(0.5 * Ka), complex)
        F, G = C.real, C.imag
        kap = 1.0 if self.added_inertia else 0.0
        out = {k: np.zeros_like(Ka) for k in DERIVATIVE_NAMES}
        out.update({
            "H1": -2 * np.pi * F / Ka,
            "H2": np.pi / (2 * Ka) * (1 + F + 4 * G / Ka),
            "H3": 2 * np.pi / Ka * (F / Ka - G / 4),
            "H4": np.pi / 2 * (1 + 4 * G / Ka),
            "A1": -np.pi * F / (2 * Ka),
            "A2": -np.pi / (8 * Ka) * (1 - F - 4 * G / Ka),
            "A3": np.pi / (2 * Ka) * (F / Ka - G / 4) + kap * np.pi / 64,
            "A4": np.pi * G / (2 * Ka),
        })
        return out


def flat_plate(chord_m: float, added_inertia: bool = False, c_function=None,
               k_range: tuple = (0.01, 6.0)) -> FlatPlateDerivatives:
    """:class:`FlatPlateDerivatives` of a deck of chord ``B`` [m] (``K`` range for fits)."""
    _positive("chord_m", chord_m)
    conv = "kept (kappa = 1)" if added_inertia else "dropped (Scanlan/wawi, kappa = 0)"
    return FlatPlateDerivatives(float(chord_m), "flat-plate",
                                f"Theodorsen (1935) closed form; apparent-inertia moment {conv}",
                                tuple(k_range), False, bool(added_inertia), c_function)


@dataclass(frozen=True)
class TabulatedDerivatives(FlutterDerivatives):
    """Scanlan derivatives tabulated against ``K``, interpolated linearly in ``v = 1/K``.

    Outside the table the end values are held (``extrapolation="hold"``) or the request is
    refused (``"error"``).
    """

    K: tuple = ()
    data: dict = field(default_factory=dict, compare=False)
    extrapolation: str = "hold"

    def values(self, K: ArrayLike) -> dict:
        Ka = np.asarray(K, float)
        kt = np.asarray(self.K, float)
        if self.extrapolation == "error" and (np.any(Ka < kt.min() * (1 - 1e-12))
                                              or np.any(Ka > kt.max() * (1 + 1e-12))):
            raise BridgeflapInputError("reduced_frequency",
                                       f"outside the table K in [{kt.min():g}, {kt.max():g}]")
        vt = 1.0 / kt
        order = np.argsort(vt)
        v = 1.0 / Ka
        out = {}
        for name in DERIVATIVE_NAMES:
            col = self.data.get(name)
            out[name] = (np.zeros_like(Ka) if col is None
                         else np.interp(v, vt[order], np.asarray(col, float)[order]))
        return out


def tabulated(K: ArrayLike, data: dict, chord_m: float, name: str = "table", source: str = "",
              argument: str = "K", extrapolation: str = "hold") -> TabulatedDerivatives:
    """Validated :class:`TabulatedDerivatives` (``argument`` names the kind of ``K``).

    Raises
    ------
    BridgeflapInputError
        Unknown derivative name, columns of different lengths (tables over different ranges),
        NaN, fewer than 2 points, repeated or non-positive arguments.
    """
    _positive("chord_m", chord_m)
    Ka = convert_argument(np.asarray(K, float), argument, "K")
    if Ka.ndim != 1 or Ka.size < 2:
        raise BridgeflapInputError("reduced_frequency", "the table needs at least two points")
    if np.any(~np.isfinite(Ka)) or np.any(Ka <= 0):
        raise BridgeflapInputError("reduced_frequency", "must be finite and > 0")
    if np.unique(Ka).size != Ka.size:
        raise BridgeflapInputError("reduced_frequency", "repeated table points")
    clean = {}
    for key, col in data.items():
        if key not in DERIVATIVE_NAMES:
            raise BridgeflapInputError("derivatives", f"unknown derivative {key!r}; expected "
                                       f"{', '.join(DERIVATIVE_NAMES)}")
        arr = np.asarray(col, float)
        if arr.shape != Ka.shape:
            raise BridgeflapInputError(f"derivatives.{key}", f"has {arr.size} values for "
                                       f"{Ka.size} reduced velocities (all tables must share one "
                                       "reduced-velocity range)")
        if np.any(~np.isfinite(arr)):
            raise BridgeflapInputError(f"derivatives.{key}", "contains NaN or inf")
        clean[key] = tuple(arr.tolist())
    if extrapolation not in ("hold", "error"):
        raise BridgeflapInputError("extrapolation", "must be 'hold' or 'error'")
    lateral = any(k in clean for k in ("H5", "H6", "A5", "A6", "P1", "P2", "P3", "P4", "P5",
                                       "P6"))
    return TabulatedDerivatives(float(chord_m), name, source, (float(Ka.min()), float(Ka.max())),
                                lateral, tuple(Ka.tolist()), clean, extrapolation)


@dataclass(frozen=True)
class PolimiDerivatives(FlutterDerivatives):
    """PoliMi coefficients tabulated against ``v = 1/K``, converted by :func:`polimi_to_scanlan`.

    Evaluation as in wawi's IABSE 1.1c data: the PoliMi coefficients are interpolated linearly
    in ``v`` and held at their end values outside the table (scipy ``interp1d`` with
    ``bounds_error=False`` and ``fill_value=(first, last)``), then converted. ``column_v``:
    optional own abscissae of the 6 ``h``/``a`` columns (IABSE 2a; ``p`` stays on ``v``)."""

    v: tuple = ()
    polimi: dict = field(default_factory=dict, compare=False)
    column_v: tuple = ()

    def values(self, K: ArrayLike) -> dict:
        Ka, vt = np.asarray(K, float), np.asarray(self.v, float)
        v = np.atleast_1d(1.0 / Ka).ravel()
        ax = [np.asarray(c, float) for c in self.column_v] or [vt] * 6  # own h/a abscissae
        tabs = {f: np.column_stack([np.interp(v, vt if f == "p" else ax[i],
                                              np.asarray(self.polimi[f], float)[:, i])
                                    for i in range(6)]) for f in "hap"}
        out = polimi_to_scanlan(v, tabs["h"], tabs["a"], tabs["p"])
        return {k: val.reshape(Ka.shape) for k, val in out.items()}


def _positive(name, value):
    if not (isinstance(value, int | float | np.floating) and np.isfinite(value) and value > 0):
        raise BridgeflapInputError(name, f"must be a positive number, got {value!r}")


# --------------------------------------------------------------------------- Roger RFA


@dataclass(frozen=True)
class RogerFit:
    """Roger rational approximation of ``Qn`` (module docstring).

    Attributes
    ----------
    R : ndarray (3 + n_lags, d, d)
        ``R0, R1, R2, R_3..`` (real, non-dimensional).
    poles : ndarray (n_lags,)
        ``gamma_j > 0`` in ``pbar = s B / U`` [-].
    chord_m : float
    k_fit : ndarray
        Reduced frequencies of the fit [-].
    errors : dict
        Per derivative ``X``: ``max |K^2 (X_fit - X)| / max |K^2 X|`` over the fit grid (the
        relative error of its term in the loads; ``None`` for a derivative identically zero).
    max_error : float
        Largest of ``errors``.
    """

    R: np.ndarray
    poles: np.ndarray
    chord_m: float
    k_fit: np.ndarray
    errors: dict
    max_error: float
    name: str = "roger"

    @property
    def n_lags(self) -> int:
        """Number of lag poles."""
        return int(self.poles.size)

    def evaluate(self, K: ArrayLike) -> NDArray[np.complex128]:
        """Fitted ``Qn(iK)``, shape ``K.shape + (d, d)``."""
        p = 1j * np.asarray(K, float)[..., None, None]
        out = self.R[0] + self.R[1] * p + self.R[2] * p * p
        for j, g in enumerate(self.poles):
            out = out + self.R[3 + j] * (p / (p + g))
        return out

    def derivatives(self, K: ArrayLike) -> dict:
        """The derivatives implied by the fit at ``K`` (inverse of :meth:`matrix`)."""
        Ka = np.asarray(K, float)
        Q = self.evaluate(Ka) / (Ka ** 2)[..., None, None]
        d = self.R.shape[1]
        out = {k: np.zeros_like(Ka) for k in DERIVATIVE_NAMES}
        for (r, c), (re, im) in _ENTRIES.items():
            if r < d and c < d:
                out[re], out[im] = Q[..., r, c].real, Q[..., r, c].imag
        return out

    def summary(self) -> dict:
        """JSON-ready description."""
        return {"rfa_form": "roger", "n_lags": self.n_lags,
                "lag_poles_pbar": self.poles.tolist(),
                "fit_k_min": float(self.k_fit.min()), "fit_k_max": float(self.k_fit.max()),
                "fit_relative_error": dict(self.errors),
                "fit_max_relative_error": self.max_error}


def _basis(K, poles):
    """Columns ``1, pbar, pbar^2, pbar/(pbar + gamma_j)`` at ``pbar = iK``: (m, 3 + n)."""
    p = 1j * np.asarray(K, float)[:, None]
    cols = [np.ones_like(p), p, p * p] + [p / (p + g) for g in poles]
    return np.hstack(cols)


def _solve_entries(K, poles, Qn, weights):
    """Least-squares real ``R`` (3 + n, d, d) for fixed poles, entry by entry (weighted)."""
    Phi = _basis(K, poles)
    A = np.vstack([Phi.real, Phi.imag])
    d = Qn.shape[-1]
    R = np.zeros((Phi.shape[1], d, d))
    for r in range(d):
        for c in range(d):
            y = Qn[:, r, c]
            if not np.any(y):
                continue
            w = np.concatenate([np.full(K.size, weights[0, r, c]),
                                np.full(K.size, weights[1, r, c])])[:, None]
            b = np.concatenate([y.real, y.imag]) * w[:, 0]
            R[:, r, c] = np.linalg.lstsq(A * w, b, rcond=None)[0]
    return R


def _weights(Qn, weighting):
    """(2, d, d) weights of the real and imaginary parts (see :func:`fit_roger`)."""
    if weighting == "derivative":
        scale = np.stack([np.max(np.abs(Qn.real), axis=0), np.max(np.abs(Qn.imag), axis=0)])
    elif weighting == "row":
        row = np.max(np.abs(Qn), axis=(0, 2))
        scale = np.broadcast_to(row[None, :, None], (2,) + Qn.shape[1:]).copy()
    else:
        raise BridgeflapInputError("weighting", f"must be 'derivative' or 'row', got "
                                   f"{weighting!r}")
    return np.where(scale > 0, 1.0 / np.where(scale > 0, scale, 1.0), 0.0)


def fit_roger(source: FlutterDerivatives, n_lags: int = 2, n_dof: int | None = None,
              poles=None, k_range: tuple | None = None, n_points: int = 200,
              optimise_poles: bool = True, weighting: str = "derivative") -> RogerFit:
    """Fit a Roger RFA to a derivative source (module docstring).

    Parameters
    ----------
    source : FlutterDerivatives
    n_lags : int
        Number of lag poles (ignored when ``poles`` is given).
    n_dof : int, optional
        2 (heave, pitch) or 3 (with lateral); default 3 when the source has lateral data.
    poles : array, optional
        Starting (or, with ``optimise_poles=False``, fixed) poles ``gamma_j > 0`` in
        ``pbar = s B / U``. Default ``geomspace`` over the fit range.
    k_range : (float, float), optional
        Fit range of ``K``; default the source's ``k_range``.
    n_points : int
        Log-spaced fit points.

    Notes
    -----
    Weights (``weighting``): ``"derivative"`` scales the real and the imaginary part of each
    entry of ``Qn`` (one derivative each, times ``K^2``) by ``1 / max |part|`` over the range,
    so every derivative is fitted to the same relative accuracy; ``"row"`` scales each load
    (lift, moment, drag) by its largest term, so that derivatives too small to matter (and
    often the noisiest in measured tables) do not spend the poles. The reported error is the
    same in both: per derivative ``X``, ``max |K^2 (X_fit - X)| / max |K^2 X|`` over the fit
    grid (the error of its term in the loads, relative to that term). The pole search
    minimises the weighted residual over ``log gamma`` (scipy ``least_squares``), so
    ``gamma_j = exp(.) > 0`` and every lag state is stable; given poles must be positive
    (``BridgeflapInputError`` otherwise). Poles that coalesce (within 0.1 %) are merged, so
    ``n_lags`` of the result may be smaller than asked: more lags than the data support (a
    7-point measured table) do not add information.
    """
    d = n_dof if n_dof is not None else (3 if source.lateral else 2)
    if d not in (2, 3):
        raise BridgeflapInputError("n_dof", f"must be 2 or 3, got {d}")
    lo, hi = k_range if k_range is not None else source.k_range
    if not (np.isfinite(lo) and np.isfinite(hi) and 0 < lo < hi):
        raise BridgeflapInputError("k_range", f"must satisfy 0 < K_min < K_max, got {lo}, {hi}")
    K = np.geomspace(lo, hi, int(n_points))
    Qn = source.matrix(K, d)
    weights = _weights(Qn, weighting)
    if poles is None:
        if int(n_lags) != n_lags or n_lags < 0:
            raise BridgeflapInputError("n_lags", f"must be an integer >= 0, got {n_lags!r}")
        start = np.geomspace(lo, hi, int(n_lags) + 2)[1:-1] if n_lags else np.zeros(0)
    else:
        start = np.asarray(poles, float).ravel()
        if np.any(~np.isfinite(start)) or np.any(start <= 0):
            raise BridgeflapInputError("poles", f"lag poles must be > 0 (stable), got "
                                       f"{start.tolist()}")

    def residual(logp):
        R = _solve_entries(K, np.exp(logp), Qn, weights)
        E = (_basis(K, np.exp(logp)) @ R.reshape(R.shape[0], -1)).reshape(Qn.shape) - Qn
        return np.concatenate([(E.real * weights[0]).ravel(), (E.imag * weights[1]).ravel()])

    logp = np.log(start) if start.size else start
    if optimise_poles and start.size:
        sol = least_squares(residual, logp, xtol=1e-10, ftol=1e-12, gtol=1e-12,
                            bounds=(np.log(lo / 100.0), np.log(10.0 * hi)))
        logp = np.sort(sol.x)
    gam = np.exp(logp)
    if gam.size > 1:  # coalesced poles (an ill-posed search): keep one of each cluster
        keep = np.concatenate([[True], np.diff(np.log(gam)) > 1e-3])
        gam = gam[keep]
    if np.any(~np.isfinite(gam)) or np.any(gam <= 0):
        raise BridgeflapInputError("poles", "the fit produced a non-positive (unstable) lag pole")
    R = _solve_entries(K, gam, Qn, weights)
    fit = RogerFit(R, gam, source.chord_m, K, {}, 0.0)
    errors = _fit_errors(source, fit, K, d)
    finite = [e for e in errors.values() if e is not None]
    return RogerFit(R, gam, source.chord_m, K, errors, float(max(finite) if finite else 0.0),
                    f"roger{gam.size}")


def _fit_errors(source, fit, K, d):
    """Per-derivative max |fit - data| / max |data| on the fit grid (``None``: zero data)."""
    data = source.values(K)
    got = fit.derivatives(K)
    out = {}
    for (r, c), names in _ENTRIES.items():
        if r >= d or c >= d:
            continue
        for name in names:
            ref = K ** 2 * np.asarray(data[name], float)
            top = float(np.max(np.abs(ref)))
            out[name] = (None if top == 0 else
                         float(np.max(np.abs(K ** 2 * got[name] - ref)) / top))
    return out
