"""Dead-load cable statics after Irvine (1974, 1981), including partial erection.

Two routes are implemented:

* :func:`three_step_single_span` -- the paper's three-step procedure for one level span
  (inextensible start, elastic cable, added deck load), using the parabolic-cable cubics
  reconstructed in docs/humber_data.md#cable-statics-equations. Used to
  cross-check the general solver.
* :func:`dead_load` -- the general "string" solution for any number of spans over
  frictionless saddles (common horizontal tension ``H``) with piecewise-uniform loads:
  the profile is ``y = M0(x)/H`` (simply supported moment diagram of the load), and ``H`` solves
  the length compatibility ``sum(stretched length - elastic stretch) = S0`` by Brent's method.
  ``S0``, the unstrained cable length, is fixed by the complete bridge at its stated main-span sag
  (the sag is "a data usually available", the paper, §2); partial erection then loads only part of
  the main span and ``H`` follows from the same ``S0``.

All loads are per cable [N/m] of horizontal length; ``H`` is per cable [N]. The cable's own
weight is ``m_c g ds/dx`` per horizontal metre (``m_c`` per metre of cable,
:class:`bridgeflap.model.structure.spec.Cable`), taken uniform within each span at the span's mean
``ds/dx = S_i/L_i`` (so that each span carries exactly its cable's weight ``m_c g S_i``) and found
by a fixed-point iteration with the profile (converged to 1e-12 in ``ds/dx``; it changes the weight
by up to 10 % in an inclined side span). Within a span the true ``ds/dx`` varies by up to 5 % (main
span, sag/span 1/12); the load distribution error this leaves is second order in the slope. Each
span has its own cable area (``EA_i``) in the length compatibility, so the compatibility flexibility
is ``sum_i L_E,i / (E A_i)``. Conventions: see :mod:`bridgeflap.model`.

References
----------
H. M. Irvine, Studies in the statics and dynamics of simple cable systems, Caltech, 1974.
H. M. Irvine, Cable Structures, MIT Press, 1981.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import brentq

from bridgeflap.model.errors import BridgeflapError
from bridgeflap.model.structure.spec import BridgeSpec

G = 9.80665  # standard gravity [m/s^2]
_GL_X, _GL_W = np.polynomial.legendre.leggauss(24)


@dataclass(frozen=True)
class SpanLoad:
    """Piecewise-uniform load on one span: ``breaks`` (m from the span's left end) and
    ``q`` [N/m per cable] on each interval; ``deck`` marks intervals carrying the deck."""

    length_m: float
    chord_rise_m: float
    breaks: np.ndarray
    q: np.ndarray
    deck: np.ndarray
    ea_n: float = np.inf
    cable_mass_kg_per_m: float = 0.0


@dataclass(frozen=True)
class CableStatics:
    """Dead-load state of the cables (per cable).

    Attributes
    ----------
    horizontal_tension_n : float
        ``H`` per cable [N], common to all spans.
    main_sag_m : float
        Sag of the main span below its chord at mid-span [m].
    span_sags_m : tuple of float
        Mid-span sag below the chord of each span [m].
    irvine_lambda_sq : float
        Irvine parameter of the main span, ``(wL/H)^2 L / (H L_E / EA)`` with the span-mean
        load ``w`` and ``L_E`` the whole cable's ``int (ds/dx)^3 dx``.
    effective_length_m : float
        ``L_E`` [m] summed over all spans (the cable runs over frictionless saddles).
    unstrained_length_m : float
        ``S0`` [m].
    flexibility_m_per_n : float
        ``sum_i L_E,i / (E A_i)`` [m/N]: the cable's length change per unit change of ``H``
        (replaces ``L_E/EA`` when the spans' areas differ).
    cable_length_m : float
        Stretched length of one cable over all spans [m].
    cable_mass_kg : float
        Mass of one cable over all spans, ``sum_i m_c,i S_i`` [kg].
    loads : tuple of SpanLoad
        The loads that produced this state.
    """

    horizontal_tension_n: float
    main_sag_m: float
    span_sags_m: tuple
    irvine_lambda_sq: float
    effective_length_m: float
    unstrained_length_m: float
    loads: tuple
    main_span_index: int
    flexibility_m_per_n: float = 0.0
    cable_length_m: float = 0.0
    cable_mass_kg: float = 0.0

    def slope(self, span: int, x: np.ndarray) -> np.ndarray:
        """Cable slope ``dy/dx`` to the horizontal [-] at ``x`` [m] in ``span``."""
        ld = self.loads[span]
        return ld.chord_rise_m / ld.length_m - _shear(ld, np.asarray(x, float)) \
            / self.horizontal_tension_n

    def profile(self, span: int, n: int = 201) -> tuple[np.ndarray, np.ndarray]:
        """Sag below the chord ``y(x)`` [m] of one span at ``n`` points ``x`` [m]."""
        ld = self.loads[span]
        x = np.linspace(0.0, ld.length_m, n)
        return x, _moment(ld, x) / self.horizontal_tension_n

    def sag(self, span: int, x: np.ndarray) -> np.ndarray:
        """Sag below the chord [m] at ``x`` [m] in ``span``."""
        return _moment(self.loads[span], np.asarray(x, dtype=float)) / self.horizontal_tension_n

    def curvature_load(self, span: int, x: np.ndarray) -> np.ndarray:
        """``-y''(x) = q(x)/H`` [1/m] (the cable-stretching weight of Irvine's h(t))."""
        ld = self.loads[span]
        idx = np.clip(np.searchsorted(ld.breaks, x, side="right") - 1, 0, len(ld.q) - 1)
        return ld.q[idx] / self.horizontal_tension_n


def span_loads(spec: BridgeSpec, fraction: float | None = None,
               stretch: tuple | None = None) -> tuple[SpanLoad, ...]:
    """Per-cable loads for each span with the main-span deck erected over ``fraction``.

    The cable's own weight ``m_c,i g (S_i/L_i)`` acts everywhere (``stretch`` gives each span's
    mean ``ds/dx = S_i/L_i``; 1 when omitted, the horizontal-cable approximation); half the deck
    weight hangs from each cable where the deck is in place (erected symmetrically from the
    main-span mid-point; side-span decks in place throughout, README "Erection").
    """
    f = spec.erected_fraction if fraction is None else fraction
    p = 0.5 * spec.deck.mass_kg_per_m * G
    stretch = (1.0,) * len(spec.spans) if stretch is None else stretch
    complete = fraction is not None and fraction >= 1.0
    m = spec.main_span_index
    loads = []
    for i, s in enumerate(spec.spans):
        L = s.length_m
        side_f = 1.0 if complete else spec.side_span_deck_fraction(i)
        if i == m and f < 1.0:
            a, b = 0.5 * L * (1 - f), 0.5 * L * (1 + f)
            breaks = np.array([0.0, a, b, L])
            deck = np.array([False, True, False])
        elif i != m and s.suspended_deck and 0.0 < side_f < 1.0:
            # erected from the tower outwards: the tower is the end next to the main span
            if i < m:
                breaks = np.array([0.0, L * (1 - side_f), L])
                deck = np.array([False, True])
            else:
                breaks = np.array([0.0, L * side_f, L])
                deck = np.array([True, False])
        else:
            breaks = np.array([0.0, L])
            deck = np.array([bool(s.suspended_deck) and (i == m or side_f > 0.0)])
        mc = spec.span_cable_mass_kg_per_m(i)
        q = mc * G * stretch[i] + p * deck
        loads.append(SpanLoad(L, s.chord_rise_m, breaks, q.astype(float), deck,
                              ea_n=spec.span_cable_area_m2(i) * spec.cable.modulus_pa,
                              cable_mass_kg_per_m=mc))
    return tuple(loads)


def _shear_and_moment_coeffs(ld: SpanLoad):
    """Reactions of the simply supported span under the piecewise load."""
    L = ld.length_m
    seg_len = np.diff(ld.breaks)
    seg_mid = 0.5 * (ld.breaks[1:] + ld.breaks[:-1])
    total = float(np.sum(ld.q * seg_len))
    moment_about_right = float(np.sum(ld.q * seg_len * (L - seg_mid)))
    ra = moment_about_right / L
    return ra, total


def _load_integrals(ld: SpanLoad, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Q(x) = int_0^x q, and Q1(x) = int_0^x q(t)(x - t) dt."""
    x = np.asarray(x, dtype=float)
    Q = np.zeros_like(x)
    Q1 = np.zeros_like(x)
    for a, b, q in zip(ld.breaks[:-1], ld.breaks[1:], ld.q, strict=True):
        u = np.clip(x - a, 0.0, b - a)  # loaded length of this interval to the left of x
        Q += q * u
        # int_a^{a+u} q (x - t) dt = q [u x - (a u + u^2/2)]
        Q1 += q * (u * x - (a * u + 0.5 * u * u))
    return Q, Q1


def _moment(ld: SpanLoad, x: np.ndarray) -> np.ndarray:
    ra, _ = _shear_and_moment_coeffs(ld)
    _, Q1 = _load_integrals(ld, x)
    return ra * np.asarray(x) - Q1


def _shear(ld: SpanLoad, x: np.ndarray) -> np.ndarray:
    ra, _ = _shear_and_moment_coeffs(ld)
    Q, _ = _load_integrals(ld, x)
    return ra - Q


def _span_integrals(ld: SpanLoad, H: float) -> tuple[float, float, float]:
    """(int ds, int (ds/dx)^2 dx, int (ds/dx)^3 dx) over the span at tension H.

    Gauss-Legendre on each uniform-load interval, where the slope is linear: exact to
    rounding for the polynomial parts, spectrally accurate for the square root.
    """
    c = ld.chord_rise_m / ld.length_m
    s1 = s2 = s3 = 0.0
    for a, b in zip(ld.breaks[:-1], ld.breaks[1:], strict=True):
        if b <= a:
            continue
        x = 0.5 * (b - a) * _GL_X + 0.5 * (a + b)
        w = 0.5 * (b - a) * _GL_W
        slope = c - _shear(ld, x) / H
        d2 = 1.0 + slope * slope
        s1 += float(np.sum(w * np.sqrt(d2)))
        s2 += float(np.sum(w * d2))
        s3 += float(np.sum(w * d2 ** 1.5))
    return s1, s2, s3


def unstrained_length(loads, H: float, ea: float | None = None) -> float:
    """``S0 = sum(int ds - (H/EA_i) int (ds/dx)^2 dx)`` [m] (stretch of ``T = H ds/dx``).

    ``ea`` [N] overrides every span's own ``EA_i`` (``SpanLoad.ea_n``) when given.
    """
    total = 0.0
    for ld in loads:
        s1, s2, _ = _span_integrals(ld, H)
        total += s1 - H / (ld.ea_n if ea is None else ea) * s2
    return total


def _stretch(loads, H: float) -> tuple:
    """Mean ``ds/dx`` of each span at tension ``H``."""
    return tuple(_span_integrals(ld, H)[0] / ld.length_m for ld in loads)


def reference_state(spec: BridgeSpec, tol: float = 1e-12) -> tuple[float, tuple]:
    """``(H [N], stretch)`` of the complete bridge at the stated main-span sag.

    ``H = M0(L/2) / d`` with the cable weight along the cable; fixed point in ``stretch``.
    """
    stretch = (1.0,) * len(spec.spans)
    for _ in range(50):
        loads = span_loads(spec, 1.0, stretch)
        ld = loads[spec.main_span_index]
        H = float(_moment(ld, np.array([0.5 * ld.length_m]))[0] / spec.cable.main_sag_m)
        new = _stretch(loads, H)
        if max(abs(a - b) for a, b in zip(new, stretch, strict=True)) < tol:
            return H, new
        stretch = new
    raise BridgeflapError("cable statics: the cable-weight fixed point did not converge")


def reference_tension(spec: BridgeSpec) -> float:
    """H [N] of the complete bridge at the stated main-span sag (``M0(L/2) / d``)."""
    return reference_state(spec)[0]


def solve_tension(loads, s0: float, ea: float | None, h_guess: float) -> float:
    """Solve the compatibility ``unstrained_length(loads, H) = S0`` for H by Brent's method."""

    def residual(h):
        return unstrained_length(loads, h, ea) - s0

    lo, hi = 0.5 * h_guess, 2.0 * h_guess
    for _ in range(40):
        if residual(lo) > 0 > residual(hi):
            break
        lo *= 0.5
        hi *= 2.0
    else:  # pragma: no cover - would need absurd input
        raise BridgeflapError("cable statics: could not bracket the horizontal tension")
    return float(brentq(residual, lo, hi, xtol=1e-9 * h_guess, rtol=1e-14, maxiter=200))


def dead_load(spec: BridgeSpec, tol: float = 1e-12) -> CableStatics:
    """Dead-load cable statics of ``spec`` (complete or partially erected).

    Returns
    -------
    CableStatics
    """
    h_ref, stretch = reference_state(spec)
    full = span_loads(spec, 1.0, stretch)
    s0 = unstrained_length(full, h_ref)
    if not spec.is_erecting or all(
            spec.side_span_deck_fraction(i) == 1.0 for i in range(len(spec.spans))) \
            and spec.erected_fraction >= 1.0:
        return _statics(spec, full, h_ref, s0)
    H = h_ref
    for _ in range(50):
        loads = span_loads(spec, None, stretch)
        H = solve_tension(loads, s0, None, H)
        new = _stretch(loads, H)
        if max(abs(a - b) for a, b in zip(new, stretch, strict=True)) < tol:
            break
        stretch = new
    else:  # pragma: no cover - contraction factor is the cable slope squared
        raise BridgeflapError("cable statics: the cable-weight fixed point did not converge")
    return _statics(spec, loads, H, s0)


def _statics(spec, loads, H, s0) -> CableStatics:
    sags = tuple(float(_moment(ld, np.array([0.5 * ld.length_m]))[0] / H) for ld in loads)
    ints = [_span_integrals(ld, H) for ld in loads]
    le = sum(i[2] for i in ints)
    flex = sum(i[2] / ld.ea_n for i, ld in zip(ints, loads, strict=True))
    length = sum(i[0] for i in ints)
    mass = sum(i[0] * ld.cable_mass_kg_per_m for i, ld in zip(ints, loads, strict=True))
    m = spec.main_span_index
    ld = loads[m]
    w_mean = float(np.sum(ld.q * np.diff(ld.breaks)) / ld.length_m)
    L = ld.length_m
    lam2 = (w_mean * L / H) ** 2 * L / (H * flex)
    return CableStatics(horizontal_tension_n=float(H), main_sag_m=sags[m], span_sags_m=sags,
                        irvine_lambda_sq=float(lam2), effective_length_m=float(le),
                        unstrained_length_m=float(s0), loads=loads, main_span_index=m,
                        flexibility_m_per_n=float(flex), cable_length_m=float(length),
                        cable_mass_kg=float(mass))


# ------------------------------------------------------------------ the paper's three-step route


@dataclass(frozen=True)
class ThreeStepResult:
    """States of the three-step procedure (one level span, per cable)."""

    h_inextensible_n: float
    h_elastic_n: float
    h_loaded_n: float
    sag_inextensible_m: float
    sag_elastic_m: float
    sag_loaded_m: float


def _irvine_lambda_sq_parabolic(w, L, H, d, ea):
    le = L * (1.0 + 8.0 * (d / L) ** 2)
    return (w * L / H) ** 2 * L / (H * le / ea)


def three_step_single_span(length_m: float, cable_load_n_m: float, deck_load_n_m: float,
                           ea_n: float, sag0_m: float) -> ThreeStepResult:
    """The paper's §2 three-step procedure for one level span (parabolic cable,
    docs/humber_data.md#cable-statics-equations).

    Step 1: inextensible cable under its own weight at assumed sag ``sag0``:
    ``H0 = w L^2 / (8 d0)``. Step 2: elasticity on, ``(24/lambda0^2) x^3 + x^2 - 1 = 0`` for
    ``x = H/H0``. Step 3: deck load ``p`` added, ``h*^3 + (2 + l^2/24) h*^2 + (1 + l^2/12) h*
    - (l^2/12) r (1 + r/2) = 0`` with ``r = p/w``, ``H -> H (1 + h*)``.
    """
    L, w, p = length_m, cable_load_n_m, deck_load_n_m
    h0 = w * L * L / (8.0 * sag0_m)
    lam0 = _irvine_lambda_sq_parabolic(w, L, h0, sag0_m, ea_n)
    x = _positive_root([24.0 / lam0, 1.0, 0.0, -1.0])
    h1 = x * h0
    d1 = w * L * L / (8.0 * h1)
    lam1 = _irvine_lambda_sq_parabolic(w, L, h1, d1, ea_n)
    r = p / w
    if r == 0.0:
        hs = 0.0  # no deck load: h* = 0 is the exact root of the step-3 cubic
    else:
        hs = _positive_root([1.0, 2.0 + lam1 / 24.0, 1.0 + lam1 / 12.0,
                             -(lam1 / 12.0) * r * (1 + r / 2)])
    h2 = h1 * (1.0 + hs)
    d2 = (w + p) * L * L / (8.0 * h2)
    return ThreeStepResult(h0, h1, h2, sag0_m, d1, d2)


def three_step_for_final_sag(length_m, cable_load_n_m, deck_load_n_m, ea_n, final_sag_m,
                             ) -> tuple[ThreeStepResult, float]:
    """Iterate the assumed inextensible sag until the loaded sag equals ``final_sag_m``.

    Returns the converged result and the final residual [m].
    """

    def res(d0):
        return three_step_single_span(length_m, cable_load_n_m, deck_load_n_m, ea_n,
                                      d0).sag_loaded_m - final_sag_m

    lo, hi = 0.2 * final_sag_m, 1.5 * final_sag_m
    if res(lo) * res(hi) > 0:
        raise BridgeflapError(f"cable statics: final sag {final_sag_m} m cannot be reached from "
                              f"inextensible sags in [{lo:.3g}, {hi:.3g}] m")
    d0 = brentq(res, lo, hi, xtol=1e-12)
    out = three_step_single_span(length_m, cable_load_n_m, deck_load_n_m, ea_n, d0)
    return out, out.sag_loaded_m - final_sag_m


def _positive_root(coeffs) -> float:
    roots = np.roots(coeffs)
    real = roots[np.abs(roots.imag) < 1e-9 * max(1.0, np.abs(roots).max())].real
    pos = real[real > 0]
    if len(pos) != 1:
        raise BridgeflapError(f"cable statics: expected one positive root, got {roots}")
    return float(pos[0])
