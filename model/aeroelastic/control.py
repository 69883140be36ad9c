"""Flap compensator K(s) and the controller definition (flap layout, gain limit).

The compensator of the paper (§6) drives a flap angle ``beta`` [rad] from the local deck
pitch ``alpha`` [rad] (sign conventions: see :mod:`bridgeflap.model`)::

    K(s) = (b2 s^2 + b1 s + b0) / (a2 s^2 + a1 s + 1)

The leading- and trailing-edge flaps use the same K with opposite sign (the paper, §6, "actually
anti-symmetric"; docs/methods.md#compensator-design); that sign is applied where the flap loads are
assembled, not here: this module describes K and where the flaps are. "Gain limited to 15" is read
as ``sup_w |K(jw)| <= 15`` (docs/methods.md#compensator-design), see :meth:`Compensator.max_gain`.

The realisation (:func:`canonical_realisation`) is written once for numeric and CasADi
coefficients through :mod:`bridgeflap.model.aeroelastic.backend`; the symbolic closed loop
(:mod:`bridgeflap.model.aeroelastic.symbolic`) and the numeric one (:meth:`Compensator.state_space`)
both use it. The file I/O is :mod:`bridgeflap.model.aeroelastic.controller_file`
(``load_controller``, ``save_controller``, also ``from bridgeflap.model import ...``);
python-control objects come from
:mod:`bridgeflap.model.aeroelastic.python_control` (lazily).

May import: the foundation, :mod:`bridgeflap.model.aeroelastic.backend` and (lazily)
:mod:`bridgeflap.model.aeroelastic.python_control`; nothing that imports this module.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from bridgeflap.model.aeroelastic import backend as bk
from bridgeflap.model.errors import BridgeflapInputError

__all__ = [
    "Compensator",
    "Controller",
    "canonical_realisation",
    "DEFAULT_FLAP_CHORD_M",
    "DerivativeFeedthrough",
    "PlantRecord",
]

#: Chordwise flap size of the paper, §6 [m] ("the width of the flap is assumed to be 3 m"); the
#: chord of a controller that does not record its own (:attr:`Controller.chord_m`).
DEFAULT_FLAP_CHORD_M = 3.0

#: Default dense frequency grid of :meth:`Compensator.max_gain` [rad/s].
_DEFAULT_OMEGA = np.logspace(-4.0, 3.0, 4001)


def _check_number(fieldname: str, value: Any) -> float:
    """Return ``value`` as a float, or raise if it is not a finite real number."""
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise BridgeflapInputError(fieldname, f"must be a number, got {type(value).__name__}")
    try:
        value = float(value)
    except OverflowError:  # an integer beyond 1.8e308
        raise BridgeflapInputError(fieldname, "number too large") from None
    if not math.isfinite(value):
        raise BridgeflapInputError(fieldname, f"must be finite, got {value!r}")
    return value


def canonical_realisation(theta):
    """Controllable canonical realisation of a second-order ``K(s)``, ``theta = (b2, b1, b0, a2,
    a1)`` with ``a2 != 0``, for numeric or CasADi-symbolic ``theta``
    (:mod:`bridgeflap.model.aeroelastic.backend`).

    Returns ``(Ac, Bc, Cc, Dc)`` with ``Dc = b2/a2`` a scalar (formulas in
    :meth:`Compensator.state_space`).
    """
    b2, b1, b0, a2, a1 = (theta[i] for i in range(5))
    d1, d0 = a1 / a2, 1.0 / a2
    c2, c1, c0 = b2 / a2, b1 / a2, b0 / a2
    Ac = bk.matrix([[0.0, 1.0], [-d0, -d1]])
    Cc = bk.matrix([[c0 - c2 * d0, c1 - c2 * d1]])
    return Ac, np.array([[0.0], [1.0]]), Cc, c2


@dataclass(frozen=True)
class DerivativeFeedthrough:
    """Flap angle and its first two time derivatives as linear maps.

    ``[beta; beta_dot; beta_ddot] = Gx @ xc + Ga @ [alpha; alpha_dot; alpha_ddot]``.

    Attributes
    ----------
    Gx : numpy.ndarray
        (3, n_c) map from the compensator state ``xc`` [state units].
    Ga : numpy.ndarray
        (3, 3) lower-triangular map from ``alpha`` [rad], ``alpha_dot`` [rad/s] and
        ``alpha_ddot`` [rad/s^2].
    """

    Gx: np.ndarray
    Ga: np.ndarray


@dataclass(frozen=True)
class Compensator:
    """Second-order (or first-order) lead-lag compensator from deck pitch to flap angle.

    ``K(s) = (b2 s^2 + b1 s + b0) / (a2 s^2 + a1 s + 1)``, the paper §6.

    Parameters
    ----------
    b2 : float
        Numerator s^2 coefficient [s^2] (flap angle per pitch, rad/rad, times s^2).
    b1 : float
        Numerator s coefficient [s].
    b0 : float
        Static gain [rad/rad].
    a2 : float
        Denominator s^2 coefficient [s^2]; ``a2 >= 0``. With ``a2 == 0`` the compensator is
        first order and ``b2`` must be 0 (properness).
    a1 : float
        Denominator s coefficient [s]; ``a1 > 0``.

    Raises
    ------
    BridgeflapInputError
        Field ``"controller.<name>"``: non-finite coefficient, ``a2 < 0`` or ``a1 <= 0``
        ("unstable compensator: ..."), or ``a2 == 0`` with ``b2 != 0`` ("improper ...").

    Notes
    -----
    With ``a2, a1 > 0`` the denominator ``a2 s^2 + a1 s + 1`` is Hurwitz (Routh for a
    quadratic: all coefficients of one sign), so K is stable. ``a2 == 0`` is admitted as the
    first-order limit so that an optimiser bound ``a2 >= 0`` is harmless.
    """

    b2: float
    b1: float
    b0: float
    a2: float
    a1: float

    def __post_init__(self):
        """Validate the coefficients (finite, stable, proper)."""
        for name in ("b2", "b1", "b0", "a2", "a1"):
            object.__setattr__(self, name, _check_number(f"controller.{name}", getattr(self, name)))
        if self.a2 < 0.0:
            raise BridgeflapInputError(
                "controller.a2",
                f"unstable compensator: a2 = {self.a2!r} < 0 (denominator a2 s^2 + a1 s + 1 "
                "has a right-half-plane root)",
            )
        if self.a1 <= 0.0:
            raise BridgeflapInputError(
                "controller.a1",
                f"unstable compensator: a1 = {self.a1!r} <= 0 (denominator a2 s^2 + a1 s + 1 "
                "is not Hurwitz)",
            )
        if self.a2 == 0.0 and self.b2 != 0.0:
            raise BridgeflapInputError(
                "controller.b2",
                f"improper compensator: b2 = {self.b2!r} != 0 with a2 = 0 "
                "(numerator degree exceeds denominator degree)",
            )

    # ------------------------------------------------------------------ frequency domain
    @property
    def order(self) -> int:
        """Number of compensator states n_c (2 if ``a2 > 0`` else 1)."""
        return 2 if self.a2 > 0.0 else 1

    def frequency_response(self, omega) -> np.ndarray:
        """Evaluate K(j omega).

        Parameters
        ----------
        omega : array_like
            Angular frequency [rad/s].

        Returns
        -------
        numpy.ndarray
            Complex K(j omega) [rad/rad], same shape as ``omega``.
        """
        s = 1j * np.asarray(omega, dtype=float)
        return (self.b2 * s**2 + self.b1 * s + self.b0) / (self.a2 * s**2 + self.a1 * s + 1.0)

    def high_frequency_gain(self) -> float:
        """Return ``lim_{w->inf} |K(jw)|`` [rad/rad]: ``|b2/a2|``, or ``|b1/a1|`` if first order.

        Returns
        -------
        float
            The gain [rad/rad] as the frequency goes to infinity.
        """
        if self.a2 > 0.0:
            return abs(self.b2 / self.a2)
        return abs(self.b1 / self.a1)

    def stationary_frequencies(self) -> np.ndarray:
        """Frequencies [rad/s] where d|K(jw)|^2 / d(w^2) = 0, w > 0.

        Returns
        -------
        numpy.ndarray
            The positive real frequencies [rad/s] (none, one or two), where ``|K|`` has a peak or a
            trough.
        """
        # |K|^2 = N(x)/D(x), x = w^2:
        # N = (b0 - b2 x)^2 + b1^2 x,  D = (1 - a2 x)^2 + a1^2 x.
        n = np.array([self.b2**2, self.b1**2 - 2.0 * self.b0 * self.b2, self.b0**2])
        d = np.array([self.a2**2, self.a1**2 - 2.0 * self.a2, 1.0])
        # N'D - ND' (the x^3 terms cancel, so this is a quadratic in x).
        num = np.polysub(np.polymul(np.polyder(n), d), np.polymul(n, np.polyder(d)))
        num = np.trim_zeros(num, "f")
        if num.size <= 1:
            return np.empty(0)
        roots = np.roots(num)
        x = roots[np.abs(roots.imag) <= 1e-9 * np.maximum(1.0, np.abs(roots.real))].real
        x = x[x > 0.0]
        return np.sqrt(x)

    def max_gain(self, omega_grid=None) -> float:
        """Return the peak gain ``sup_w |K(jw)|`` [rad/rad].

        Parameters
        ----------
        omega_grid : array_like, optional
            Frequencies [rad/s] evaluated in addition to the analytic candidates. Default:
            4001 log-spaced points on 1e-4 .. 1e3 rad/s.

        Returns
        -------
        float
            The maximum of ``|K|`` over the grid, the analytic stationary points of ``|K(jw)|^2``,
            w = 0 (``|b0|``) and the limit w -> inf (:meth:`high_frequency_gain`).

        Notes
        -----
        With ``x = w^2``, ``|K|^2 = N(x)/D(x)`` with N, D quadratics; its stationary points solve
        N'D - N D' = 0, a quadratic in x (the cubic terms cancel). The sup over w >= 0 is
        attained at one of those roots, at x = 0 or as x -> inf, so the analytic candidates
        alone give the exact value; the grid is a cheap safeguard against root round-off.
        """
        grid = _DEFAULT_OMEGA if omega_grid is None else np.asarray(omega_grid, dtype=float)
        candidates = np.concatenate([np.ravel(grid), self.stationary_frequencies(), [0.0]])
        gains = np.abs(self.frequency_response(candidates))
        return float(max(np.max(gains), self.high_frequency_gain()))

    # ------------------------------------------------------------------ state space
    def state_space(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Return the controllable canonical realisation of K(s).

        Returns
        -------
        Ac : numpy.ndarray
            (n_c, n_c) state matrix [1/s].
        Bc : numpy.ndarray
            (n_c, 1) input matrix, input ``alpha`` [rad].
        Cc : numpy.ndarray
            (1, n_c) output matrix, output ``beta`` [rad].
        Dc : numpy.ndarray
            (1, 1) feedthrough, ``b2/a2`` (``b1/a1`` if first order) [rad/rad].

        Notes
        -----
        Second order: with ``d(s) = s^2 + d1 s + d0`` (``d1 = a1/a2``, ``d0 = 1/a2``) and
        ``c_i = b_i/a2``, ``x1' = x2``, ``x2' = -d0 x1 - d1 x2 + alpha`` and
        ``beta = (c0 - c2 d0) x1 + (c1 - c2 d1) x2 + c2 alpha``. First order:
        ``x' = -x/a1 + alpha``, ``beta = (b0 - b1/a1)/a1 x + (b1/a1) alpha``.
        """
        if self.a2 > 0.0:
            Ac, Bc, Cc, c2 = canonical_realisation((self.b2, self.b1, self.b0, self.a2, self.a1))
            Dc = np.array([[c2]])
        else:
            d0 = 1.0 / self.a1
            c1, c0 = self.b1 / self.a1, self.b0 / self.a1
            Ac = np.array([[-d0]])
            Bc = np.array([[1.0]])
            Cc = np.array([[c0 - c1 * d0]])
            Dc = np.array([[c1]])
        return Ac, Bc, Cc, Dc

    def to_control(self):
        """K(s) as a ``control.TransferFunction``
        (:func:`bridgeflap.model.aeroelastic.python_control.compensator_tf`;
        python-control, the extra ``control``).

        Returns
        -------
        control.TransferFunction
            ``K(s)`` named ``K``, with input ``pitch`` and output ``beta`` [rad].

        Raises
        ------
        BridgeflapError
            python-control is not installed (the ``control`` extra).
        """
        from bridgeflap.model.aeroelastic.python_control import compensator_tf

        return compensator_tf(self)

    def second_derivative_feedthrough(self) -> DerivativeFeedthrough:
        """Flap angle derivatives as linear functions of the compensator state and the pitch.

        The flap non-circulatory loads contain ``beta_ddot``, so the state-space assembly needs
        ``beta``, ``beta_dot`` and ``beta_ddot`` in terms of ``xc`` and ``alpha``,
        ``alpha_dot``, ``alpha_ddot``.

        Returns
        -------
        DerivativeFeedthrough
            ``Gx = [Cc; Cc Ac; Cc Ac^2]`` and
            ``Ga = [[Dc, 0, 0], [Cc Bc, Dc, 0], [Cc Ac Bc, Cc Bc, Dc]]``.

        Notes
        -----
        Differentiate ``beta = Cc xc + Dc alpha`` using ``xc' = Ac xc + Bc alpha``:
        ``beta' = Cc Ac xc + Cc Bc alpha + Dc alpha'`` and
        ``beta'' = Cc Ac^2 xc + Cc Ac Bc alpha + Cc Bc alpha' + Dc alpha''``.
        """
        Ac, Bc, Cc, Dc = self.state_space()
        Gx = np.vstack([Cc, Cc @ Ac, Cc @ Ac @ Ac])
        cb = float((Cc @ Bc)[0, 0])
        cab = float((Cc @ Ac @ Bc)[0, 0])
        dc = float(Dc[0, 0])
        Ga = np.array([[dc, 0.0, 0.0], [cb, dc, 0.0], [cab, cb, dc]])
        return DerivativeFeedthrough(Gx=Gx, Ga=Ga)


@dataclass(frozen=True)
class PlantRecord:
    """The plant a controller was designed on (recorded in ``controller.toml``).

    Attributes
    ----------
    bridge : str
        Built-in bridge name or bridge file path, without the variant.
    bridge_variant : str
        ``[variants.<name>]`` applied ("" for none).
    bridge_name : str
        The bridge's own ``name``.
    bridge_sha256 : str
        SHA-256 (hex) of the bridge definition file's content (built-in bridges: the packaged
        file), or of the spec's canonical form for a spec built in memory
        (:func:`bridgeflap.model.aeroelastic.controller_file.plant_record`).
    design_modes : int
        Retained modes of the design model.
    """

    bridge: str
    bridge_variant: str
    bridge_name: str
    bridge_sha256: str
    design_modes: int

    def __post_init__(self):
        """Validate the field types (one field named per error)."""
        for name in ("bridge", "bridge_variant", "bridge_name", "bridge_sha256"):
            if not isinstance(getattr(self, name), str):
                raise BridgeflapInputError(f"controller.{name}", "must be a string")
        m = self.design_modes
        if isinstance(m, bool) or not isinstance(m, (int, np.integer)) or m < 1:
            raise BridgeflapInputError("controller.design_modes",
                                       f"must be a positive integer, got {m!r}")
        object.__setattr__(self, "design_modes", int(m))


@dataclass(frozen=True)
class Controller:
    """Compensator plus flap layout: the controller definition of the paper §6.

    Parameters
    ----------
    compensator : Compensator
        K(s) from local deck pitch [rad] to flap angle [rad].
    flap_strip_positions_m : tuple of float
        Centres of the flap strips along the main span, measured from its mid-point [m]
        (positive towards the south tower, see :mod:`bridgeflap.model` for the x direction). Each
        flap is driven by the pitch at its own strip (the paper, §6).
    flap_width_m : float
        Spanwise length of each flap pair (LE + TE flap at one strip) [m]; the chordwise
        flap size (3 m in the paper, §6) is ``flap_chord_m``.
    leading_edge : bool
        Whether the leading-edge flaps are fitted (driven by -K, the paper, §6).
    trailing_edge : bool
        Whether the trailing-edge flaps are fitted (driven by +K).
    gain_limit : float
        Upper bound on ``sup_w |K(jw)|`` [rad/rad] (15 in the paper, §6).
    flap_chord_m : float or None
        Chordwise size of each flap, measured from its edge inside the deck chord [m];
        ``None`` (a controller file without a geometry record) means
        :data:`DEFAULT_FLAP_CHORD_M`, see :attr:`chord_m`.
    plant : PlantRecord or None
        The bridge and mode count the controller was designed on (``None``: not recorded).

    Raises
    ------
    BridgeflapInputError
        Naming the field ``"controller.<name>"`` on invalid input.
    """

    compensator: Compensator
    flap_strip_positions_m: tuple[float, ...]
    flap_width_m: float
    leading_edge: bool = True
    trailing_edge: bool = True
    gain_limit: float = 15.0
    flap_chord_m: float | None = None
    plant: PlantRecord | None = None

    def __post_init__(self):
        """Validate the layout and normalise the positions to a tuple of floats."""
        if not isinstance(self.compensator, Compensator):
            raise BridgeflapInputError(
                "controller.compensator",
                f"must be a Compensator, got {type(self.compensator).__name__}",
            )
        positions = self.flap_strip_positions_m
        if isinstance(positions, (str, bytes)) or not hasattr(positions, "__iter__"):
            raise BridgeflapInputError(
                "controller.flap_strip_positions_m", "must be a list of numbers [m]"
            )
        positions = tuple(
            _check_number(f"controller.flap_strip_positions_m[{i}]", x)
            for i, x in enumerate(positions)
        )
        if not positions:
            raise BridgeflapInputError("controller.flap_strip_positions_m", "no flap strips")
        object.__setattr__(self, "flap_strip_positions_m", positions)
        width = _check_number("controller.flap_width_m", self.flap_width_m)
        if width <= 0.0:
            raise BridgeflapInputError(
                "controller.flap_width_m", f"flap width must be > 0 m, got {width!r}"
            )
        object.__setattr__(self, "flap_width_m", width)
        spacing = np.diff(np.sort(positions))
        # touching strips (spacing == width) are legal; positions computed as i * width or
        # read back from a TOML file differ from it by a few ulps, hence a relative tolerance
        # of 1e-9 (1e-7 m on a 100 m strip, far below any physical overlap)
        if spacing.size and np.min(spacing) < width * (1.0 - 1e-9):
            raise BridgeflapInputError(
                "controller.flap_strip_positions_m",
                f"flap strips overlap: spacing {np.min(spacing):.6g} m < width {width!r} m",
            )
        for name in ("leading_edge", "trailing_edge"):
            if not isinstance(getattr(self, name), bool):
                raise BridgeflapInputError(f"controller.{name}", "must be true or false")
        if not (self.leading_edge or self.trailing_edge):
            raise BridgeflapInputError(
                "controller.trailing_edge", "no flap fitted (leading_edge and trailing_edge false)"
            )
        limit = _check_number("controller.gain_limit", self.gain_limit)
        if limit <= 0.0:
            raise BridgeflapInputError(
                "controller.gain_limit", f"gain limit must be > 0, got {limit!r}"
            )
        object.__setattr__(self, "gain_limit", limit)
        if self.flap_chord_m is not None:
            chord = _check_number("controller.flap_chord_m", self.flap_chord_m)
            if chord <= 0.0:
                raise BridgeflapInputError("controller.flap_chord_m",
                                           f"flap chord must be > 0 m, got {chord!r}")
            object.__setattr__(self, "flap_chord_m", chord)
        if self.plant is not None and not isinstance(self.plant, PlantRecord):
            raise BridgeflapInputError("controller.plant", "must be a PlantRecord")

    @property
    def chord_m(self) -> float:
        """The flap chord the loop is closed with [m]: :attr:`flap_chord_m`, or
        :data:`DEFAULT_FLAP_CHORD_M` when the controller does not record one."""
        return DEFAULT_FLAP_CHORD_M if self.flap_chord_m is None else self.flap_chord_m

    @property
    def n_flaps(self) -> int:
        """Number of flap strips along the main span."""
        return len(self.flap_strip_positions_m)

    def to_statespace(self):
        """The controller (``pitch_flap[f]`` -> ``flap_te[f]``, ``flap_le[f]``) as a
        ``control.StateSpace``
        (:func:`bridgeflap.model.aeroelastic.python_control.controller_statespace`).

        Returns
        -------
        control.StateSpace
            Inputs ``pitch_flap[f]`` [rad], outputs ``flap_te[f]`` and ``flap_le[f]`` [rad], one
            per flap strip.

        Raises
        ------
        BridgeflapError
            python-control is not installed (the ``control`` extra).
        """
        from bridgeflap.model.aeroelastic.python_control import controller_statespace

        return controller_statespace(self)

    def gain_ratio(self) -> float:
        """Return ``sup_w |K(jw)| / gain_limit`` (<= 1 when the gain limit is met).

        Returns
        -------
        float
            The peak gain over the gain limit [-].
        """
        return self.compensator.max_gain() / self.gain_limit

    def gain_check(self) -> dict:
        """Whether ``sup_w |K(jw)|`` respects the controller's own ``gain_limit``.

        A relative slack of 1e-6 admits a design that sits on its limit (an optimiser meets
        the bound to its constraint tolerance, about 1e-8 on the scaled gain, and the dense
        sup is evaluated to roundoff); anything beyond is a controller that does not meet its
        own definition.

        Returns
        -------
        dict
            ``controller_max_gain`` and ``controller_gain_limit`` [rad/rad] and
            ``controller_within_gain_limit`` (bool).
        """
        gain = self.compensator.max_gain()
        return {"controller_max_gain": gain, "controller_gain_limit": self.gain_limit,
                "controller_within_gain_limit": bool(gain <= self.gain_limit * (1 + 1e-6))}
