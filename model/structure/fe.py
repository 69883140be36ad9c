"""Finite-element model of the deck hung from two cables (Abdel-Ghaffar type).

Three structurally uncoupled families on one mesh (docs/humber_data.md#deflection-theory,
reconstructed from standard linearised deflection theory; Abdel-Ghaffar 1976, 1978-80):

* **vertical** ``v`` (down), Hermite cubic beam elements::

      m v'' + EI v'''' - 2 H v'' + 2 (w/H) h(t) = p,   h = (EA/L_E) sum_spans int (w/H) v dx

  giving ``K_e = EI int N''N''^T + 2H int N'N'^T`` and one global rank-one cable-stretching term
  ``2 (EA/L_E) g g^T`` with ``g = int (q(x)/H) N dx`` over all spans (``q`` the dead load per
  cable; uniform spans give Irvine's ``w/H``);
* **torsional** ``theta`` (nose-up), linear elements::

      I_m theta'' - (GJ + 2 H (b_c/2)^2) theta'' + 2 (b_c/2)^2 (EA/L_E) g g^T  (rank one)

  with ``I_m = I_deck + 2 m_c (b_c/2)^2``;
* **lateral** deck ``u_d`` and (lumped) cable ``u_c``, Hermite elements, coupled by the hanger
  pendulum stiffness ``w_d / l_h(x)``.

Towers are rigid; every span is simply supported at its ends (the Humber deck has expansion
joints at the towers). While the main span is being erected only its erected segments carry the
deck (mass, inertia, aerodynamic strips) and the deck has half its GJ and zero EI (the paper, §2).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from bridgeflap.model.structure.cable import CableStatics, G, dead_load
from bridgeflap.model.structure.spec import BridgeSpec

FAMILIES = ("vertical", "lateral", "torsional")


@dataclass(frozen=True)
class Element:
    """One element: span index, left-end x within the span [m], length [m], deck flag,
    dead load per cable [N/m]."""

    span: int
    x0: float
    length: float
    deck: bool
    q: float


@dataclass(frozen=True)
class FamilyMatrices:
    """Mass and stiffness of one family over its free DOFs, and the maps used downstream.

    Attributes
    ----------
    M, K : ndarray
        Symmetric mass and stiffness [SI per DOF].
    strip_map : ndarray or None
        ``(n_strips, n_dof)``: field value (heave [m] or pitch [rad]) at each deck strip's
        mid-point per unit DOF; ``None`` for the lateral family.
    node_map : ndarray
        ``(n_nodes, n_dof)``: deck field at every mesh node (for plots and symmetry labels).
    """

    name: str
    M: np.ndarray
    K: np.ndarray
    strip_map: np.ndarray | None
    node_map: np.ndarray
    deck_mask: np.ndarray | None = None  # DOFs of the deck (lateral family: deck vs cables)
    #: deck part of ``M`` (vertical, torsional: deck and cables share the DOFs; ``M - M_deck``
    #: is the cables' share), for the deck kinetic-energy share of a mode
    M_deck: np.ndarray | None = None
    #: deck share of the kinetic energy if every point of the main span moved alike:
    #: ``int m_deck / int m`` over the main span
    uniform_deck_share: float = 1.0


@dataclass(frozen=True)
class StructuralModel:
    """Assembled structural model of one bridge state."""

    spec: BridgeSpec
    statics: CableStatics
    elements: tuple
    node_span: np.ndarray
    node_x: np.ndarray
    strip_x: np.ndarray
    strip_span: np.ndarray
    strip_length: np.ndarray
    families: dict = field(default_factory=dict)

    @property
    def main_span(self) -> int:
        """Index of the main span."""
        return self.spec.main_span_index

    def global_x(self, span: np.ndarray, x: np.ndarray) -> np.ndarray:
        """Distance from the north anchorage [m] of points given per span."""
        starts = np.concatenate([[0.0], np.cumsum([s.length_m for s in self.spec.spans])])
        return starts[np.asarray(span)] + np.asarray(x)


# --------------------------------------------------------------------- element matrices


def hermite_mass(m: float, l: float) -> np.ndarray:
    """Consistent mass of a Hermite beam element (DOFs v1, v1', v2, v2')."""
    return m * l / 420.0 * np.array([
        [156, 22 * l, 54, -13 * l],
        [22 * l, 4 * l * l, 13 * l, -3 * l * l],
        [54, 13 * l, 156, -22 * l],
        [-13 * l, -3 * l * l, -22 * l, 4 * l * l]])


def hermite_bending(ei: float, l: float) -> np.ndarray:
    """``EI int N''N''^T`` of a Hermite element."""
    return ei / l ** 3 * np.array([
        [12, 6 * l, -12, 6 * l],
        [6 * l, 4 * l * l, -6 * l, 2 * l * l],
        [-12, -6 * l, 12, -6 * l],
        [6 * l, 2 * l * l, -6 * l, 4 * l * l]])


def hermite_geometric(t: float, l: float) -> np.ndarray:
    """``T int N'N'^T`` of a Hermite element (string/tension stiffness)."""
    return t / (30.0 * l) * np.array([
        [36, 3 * l, -36, 3 * l],
        [3 * l, 4 * l * l, -3 * l, -l * l],
        [-36, -3 * l, 36, -3 * l],
        [3 * l, -l * l, -3 * l, 4 * l * l]])


def hermite_integral(l: float) -> np.ndarray:
    """``int N dx`` of a Hermite element."""
    return np.array([l / 2, l * l / 12, l / 2, -l * l / 12])


HERMITE_MID = (0.5, 0.125, 0.5, -0.125)  # N at xi = 1/2, rotation entries times l


def hermite_mid(l: float) -> np.ndarray:
    """Hermite shape functions at the element mid-point."""
    return np.array([0.5, l / 8, 0.5, -l / 8])


# ----------------------------------------------------------------------------- mesh


def build_mesh(spec: BridgeSpec, statics: CableStatics) -> tuple[list[Element], np.ndarray,
                                                                   np.ndarray, list[list[int]]]:
    """Elements (per span, erection front on an element boundary) and nodes."""
    target = spec.mesh.element_length_m
    elements: list[Element] = []
    node_span, node_x, span_nodes = [], [], []
    for i, ld in enumerate(statics.loads):
        xs = [0.0]
        seg_of = []
        for k, (a, b) in enumerate(zip(ld.breaks[:-1], ld.breaks[1:], strict=True)):
            if b - a <= 1e-9:
                continue
            n = max(1, math.ceil((b - a) / target - 1e-9))
            xs.extend(np.linspace(a, b, n + 1)[1:].tolist())
            seg_of.extend([k] * n)
        first = len(node_x)
        node_span.extend([i] * len(xs))
        node_x.extend(xs)
        span_nodes.append(list(range(first, first + len(xs))))
        for e, k in enumerate(seg_of):
            elements.append(Element(i, xs[e], xs[e + 1] - xs[e], bool(ld.deck[k]), float(ld.q[k])))
    return elements, np.array(node_span), np.array(node_x), span_nodes


def _element_nodes(elements, span_nodes):
    """Global node indices (left, right) of every element, in element order."""
    out = []
    count = {}
    for el in elements:
        j = count.get(el.span, 0)
        count[el.span] = j + 1
        out.append((span_nodes[el.span][j], span_nodes[el.span][j + 1]))
    return out


def _reduce(M, K, maps, keep):
    keep = np.asarray(keep)
    return (M[np.ix_(keep, keep)], K[np.ix_(keep, keep)],
            [None if m is None else m[:, keep] for m in maps])


def _end_nodes(span_nodes):
    return {nodes[0] for nodes in span_nodes} | {nodes[-1] for nodes in span_nodes}


def assemble(spec: BridgeSpec, statics: CableStatics | None = None,
             erection_gj_factor: float = 0.5, lateral: bool = True) -> StructuralModel:
    """Assemble the three families for ``spec`` (complete or partially erected).

    Parameters
    ----------
    spec : BridgeSpec
    statics : CableStatics, optional
        Dead-load state; computed by :func:`bridgeflap.model.structure.cable.dead_load` when
        omitted.
    erection_gj_factor : float
        Fraction of GJ the deck keeps while erecting (the paper, §2: one half; 1 gives the paper's
        "full GJ" comparison curve of Fig. 2).
    lateral : bool
        Also assemble the lateral family (default). False: the vertical and torsional
        families alone, all the aeroelastic state uses (a fresh-variant check builds
        thousands of them).
        An imported modal bridge (:mod:`bridgeflap.model.structure.modal_import`) gives its strips
        instead (:func:`bridgeflap.model.structure.modal_model.imported_structure`).
    """
    if getattr(spec, "structure", None) is not None:
        from bridgeflap.model.structure.modal_model import imported_structure

        return imported_structure(spec)
    statics = dead_load(spec) if statics is None else statics
    elements, node_span, node_x, span_nodes = build_mesh(spec, statics)
    enodes = _element_nodes(elements, span_nodes)
    n_nodes = len(node_x)
    H = statics.horizontal_tension_n
    # cable stretching: h L_E / EA becomes h * sum_i L_E,i / EA_i (per-span cable areas)
    stretch_k = 1.0 / statics.flexibility_m_per_n
    # mass of one cable per horizontal metre of each element: m_c,i * mean ds/dx over it
    mc_el = [_cable_mass_per_horizontal_m(spec, statics, el) for el in elements]
    half_bc = 0.5 * spec.cable.spacing_m
    deck = spec.deck
    erecting = spec.is_erecting
    ei_v = 0.0 if erecting else deck.ei_vertical_nm2
    ei_l = 0.0 if erecting else deck.ei_lateral_nm2
    gj = erection_gj_factor * deck.gj_nm2 if erecting else deck.gj_nm2
    strips = [k for k, el in enumerate(elements) if el.deck]
    ends = _end_nodes(span_nodes)

    # ---------------- vertical: Hermite, DOFs (v, v') per node
    nv = 2 * n_nodes
    Mv, Kv, gv = np.zeros((nv, nv)), np.zeros((nv, nv)), np.zeros(nv)
    Mv_deck = np.zeros((nv, nv))
    mass_v = [0.0, 0.0]  # (deck, total) mass [kg] for the uniform-motion deck share
    strip_v = np.zeros((len(strips), nv))
    for k, (el, (a, b)) in enumerate(zip(elements, enodes, strict=True)):
        d = [2 * a, 2 * a + 1, 2 * b, 2 * b + 1]
        ix = np.ix_(d, d)
        md = deck.mass_kg_per_m if el.deck else 0.0
        m = 2 * mc_el[k] + md
        Mv[ix] += hermite_mass(m, el.length)
        Mv_deck[ix] += hermite_mass(md, el.length)
        if el.span == spec.main_span_index:
            mass_v[0] += md * el.length
            mass_v[1] += m * el.length
        Kv[ix] += hermite_bending(ei_v if el.deck else 0.0, el.length)
        Kv[ix] += hermite_geometric(2 * H, el.length)
        gv[d] += el.q / H * hermite_integral(el.length)
        if el.deck:
            strip_v[strips.index(k), d] = hermite_mid(el.length)
    Kv += 2 * stretch_k * np.outer(gv, gv)
    node_v = np.zeros((n_nodes, nv))
    node_v[np.arange(n_nodes), 2 * np.arange(n_nodes)] = 1.0
    keep_v = [i for i in range(nv) if not (i % 2 == 0 and i // 2 in ends)]
    Mv_deck = Mv_deck[np.ix_(keep_v, keep_v)]
    Mv, Kv, (strip_v, node_v) = _reduce(Mv, Kv, [strip_v, node_v], keep_v)

    # ---------------- torsional: linear elements, one DOF per node
    Mt, Kt, gt = np.zeros((n_nodes, n_nodes)), np.zeros((n_nodes, n_nodes)), np.zeros(n_nodes)
    Mt_deck = np.zeros((n_nodes, n_nodes))
    mass_t = [0.0, 0.0]
    strip_t = np.zeros((len(strips), n_nodes))
    for k, (el, (a, b)) in enumerate(zip(elements, enodes, strict=True)):
        d = [a, b]
        ix = np.ix_(d, d)
        i_deck = deck.mass_inertia_kgm2_per_m if el.deck else 0.0
        inertia = 2 * mc_el[k] * half_bc ** 2 + i_deck
        l = el.length
        Mt[ix] += inertia * l / 6.0 * np.array([[2.0, 1.0], [1.0, 2.0]])
        Mt_deck[ix] += i_deck * l / 6.0 * np.array([[2.0, 1.0], [1.0, 2.0]])
        if el.span == spec.main_span_index:
            mass_t[0] += i_deck * l
            mass_t[1] += inertia * l
        kt = 2 * H * half_bc ** 2 + (gj if el.deck else 0.0)
        Kt[ix] += kt / l * np.array([[1.0, -1.0], [-1.0, 1.0]])
        gt[d] += el.q / H * np.array([l / 2, l / 2])
        if el.deck:
            strip_t[strips.index(k), d] = 0.5
    Kt += 2 * half_bc ** 2 * stretch_k * np.outer(gt, gt)
    keep_t = [i for i in range(n_nodes) if i not in ends]
    Mt_deck = Mt_deck[np.ix_(keep_t, keep_t)]
    Mt, Kt, (strip_t, node_t) = _reduce(Mt, Kt, [strip_t, np.eye(n_nodes)], keep_t)

    strip_x = np.array([elements[k].x0 + 0.5 * elements[k].length for k in strips])
    fam = {
        "vertical": FamilyMatrices("vertical", Mv, Kv, strip_v, node_v, M_deck=Mv_deck,
                                   uniform_deck_share=mass_v[0] / mass_v[1]),
        "torsional": FamilyMatrices("torsional", Mt, Kt, strip_t, node_t, M_deck=Mt_deck,
                                    uniform_deck_share=mass_t[0] / mass_t[1]),
    }
    if lateral:
        fam["lateral"] = _lateral(spec, statics, elements, enodes, n_nodes, mc_el, H, ei_l,
                                  ends)
    return StructuralModel(
        spec=spec, statics=statics, elements=tuple(elements), node_span=node_span,
        node_x=node_x, strip_x=strip_x,
        strip_span=np.array([elements[k].span for k in strips], dtype=int),
        strip_length=np.array([elements[k].length for k in strips]), families=fam)


def _lateral(spec, statics, elements, enodes, n_nodes, mc_el, H, ei_l, ends):
    """The lateral family of :func:`assemble`."""
    deck = spec.deck
    # ---------------- lateral: deck (u_d, u_d') and cables (u_c, u_c') per node
    nl = 4 * n_nodes
    Ml, Kl = np.zeros((nl, nl)), np.zeros((nl, nl))
    wd = deck.mass_kg_per_m * G
    for k, (el, (a, b)) in enumerate(zip(elements, enodes, strict=True)):
        dc = [4 * a + 2, 4 * a + 3, 4 * b + 2, 4 * b + 3]
        Ml[np.ix_(dc, dc)] += hermite_mass(2 * mc_el[k], el.length)
        Kl[np.ix_(dc, dc)] += hermite_geometric(2 * H, el.length)
        if not el.deck:
            continue
        dd = [4 * a, 4 * a + 1, 4 * b, 4 * b + 1]
        Ml[np.ix_(dd, dd)] += hermite_mass(deck.mass_kg_per_m, el.length)
        Kl[np.ix_(dd, dd)] += hermite_bending(ei_l, el.length)
        kp = wd / hanger_length(spec, statics, el.span, el.x0 + 0.5 * el.length)
        Mnn = hermite_mass(1.0, el.length)  # int N N^T
        both = dd + dc
        Kl[np.ix_(both, both)] += kp * np.block([[Mnn, -Mnn], [-Mnn, Mnn]])
    node_l = np.zeros((n_nodes, nl))
    node_l[np.arange(n_nodes), 4 * np.arange(n_nodes)] = 1.0
    touched = np.abs(np.diag(Ml)) > 0
    keep_l = [i for i in range(nl) if touched[i] and not (i % 2 == 0 and i // 4 in ends)]
    Ml, Kl, (node_l,) = _reduce(Ml, Kl, [node_l], keep_l)
    deck_mask_l = np.array([(i % 4) < 2 for i in keep_l])
    return FamilyMatrices("lateral", Ml, Kl, None, node_l, deck_mask_l)


_GL3_X, _GL3_W = np.polynomial.legendre.leggauss(3)


def _cable_mass_per_horizontal_m(spec: BridgeSpec, statics: CableStatics, el) -> float:
    """One cable's mass per horizontal metre over ``el`` [kg/m]: ``m_c,i`` times mean ``ds/dx``.

    Gauss-Legendre (3 points) over the element of ``sqrt(1 + y'^2)``; ``y'`` is linear within a
    uniform-load interval, so this is accurate to ~1e-8 for the default mesh.
    """
    x = el.x0 + 0.5 * el.length * (1.0 + _GL3_X)
    ds_dx = np.sqrt(1.0 + statics.slope(el.span, x) ** 2)
    return spec.span_cable_mass_kg_per_m(el.span) * float(0.5 * np.sum(_GL3_W * ds_dx))


def hanger_length(spec: BridgeSpec, statics: CableStatics, span: int, x: float) -> float:
    """Hanger length ``l_h`` [m] at ``x`` in ``span`` (deck level taken constant).

    The deck is taken level at ``main_sag + h_m`` below the saddles; the cable elevation follows
    the chord and the dead-load sag. Clamped below at the mid-span length ``h_m`` (side spans near
    the anchorages), an estimate that only affects the lateral pendulum stiffness.
    """
    s = spec.spans[span]
    hm = spec.deck.hanger_length_midspan_m
    sag = float(statics.sag(span, np.array([x]))[0])
    if span == spec.main_span_index:
        drop_of_chord = 0.0
    else:
        # side span: the chord falls from the saddle to the anchorage
        left_is_saddle = span > spec.main_span_index
        xi = x / s.length_m
        drop_of_chord = s.chord_rise_m * (xi if left_is_saddle else 1.0 - xi)
    deck_level = statics.main_sag_m + hm
    return max(hm, deck_level - drop_of_chord - sag)
