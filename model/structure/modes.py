"""Structural modes: eigen-solution per family, labels, Rayleigh damping, modal truncation.

Rayleigh damping ``C = a_M M + a_K K`` gives 1 % (``spec.damping.ratio``) in the first vertical
and the first torsional mode (the paper, §2); every other mode's ratio follows from
``zeta = a_M/(2 omega) + a_K omega/2``. The three families are uncoupled, so the mass-normalised
modes of each family diagonalise ``M``, ``K`` and ``C`` of the whole structure. One mode's
record, :class:`Mode`, lives in :mod:`bridgeflap.model.structure.mode` (the imported modal models
use it too) and is importable from here.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla

from bridgeflap.model.aero.basis import StructuralBasis
from bridgeflap.model.errors import BridgeflapError, BridgeflapInputError
from bridgeflap.model.results import ResultData, jsonable
from bridgeflap.model.structure.fe import StructuralModel, assemble
from bridgeflap.model.structure.mode import Mode
from bridgeflap.model.structure.spec import BridgeSpec


@dataclass(frozen=True)
class ModalModel(ResultData):
    """All modes of a bridge state, with the shapes the aerodynamics needs.

    Attributes
    ----------
    modes : tuple of Mode
        Sorted by frequency.
    shapes : dict
        ``family -> (n_dof, n_family_modes)`` mass-normalised eigenvectors, columns in the order
        of ``family_index``.
    family_index : dict
        ``family -> list of indices into modes``.
    rayleigh : tuple
        ``(a_M [1/s], a_K [s])``.
    """

    structure: StructuralModel
    modes: tuple
    shapes: dict
    family_index: dict
    rayleigh: tuple

    @property
    def spec(self) -> BridgeSpec:
        """The bridge definition."""
        return self.structure.spec

    def mode_records(self) -> list[dict]:
        """Modes as JSON-ready dicts, sorted by frequency (the rows of :meth:`table`).

        Returns
        -------
        list of dict
            Per mode: label, family, symmetry, frequency [Hz], damping ratio [-], main-span share
            [-] and the other columns of :meth:`to_dataframe`.
        """
        return [m.as_dict() for m in self.modes]

    def _rows(self) -> list[dict]:
        return self.mode_records()

    def to_dict(self) -> dict:
        """Strict-JSON ``{"bridge", "erected_fraction", "modes"}`` (shapes: :meth:`deck_shapes`).

        Returns
        -------
        dict
            ``bridge``, ``erected_fraction`` [-] and ``modes`` (:meth:`mode_records`), NaN as
            ``None``.
        """
        return jsonable({"bridge": self.spec.name,
                         "erected_fraction": self.spec.erected_fraction,
                         "modes": self.mode_records()})

    def _headline(self) -> dict:
        """Bridge, stage, mode count and the lowest mode of each family."""
        out = {"bridge": self.spec.name, "erected_fraction": self.spec.erected_fraction,
               "modes": len(self.modes)}
        for fam, idx in self.family_index.items():
            if idx:
                m = self.modes[idx[0]]
                out[f"lowest_{fam}"] = f"{m.label} {m.frequency_hz:.4g} Hz"
        return out

    def deck_shapes(self) -> dict:
        """Mass-normalised deck mode shapes at the structural nodes, per mode.

        Returns
        -------
        dict
            ``node_x_m`` (n_node,) node positions from the north anchorage [m],
            ``node_span`` (n_node,) span index, ``labels`` (n_mode,), ``family`` (n_mode,),
            ``frequency_hz`` (n_mode,) and ``shape`` (n_mode, n_node): the deck field of each
            mode (heave [m], pitch [rad] or lateral [m] per unit modal coordinate, by family).
        """
        st = self.structure
        shape = np.array([st.families[m.family].node_map @ self.shape(i)
                          for i, m in enumerate(self.modes)])
        return {"node_x_m": np.asarray(st.global_x(st.node_span, st.node_x), float),
                "node_span": np.asarray(st.node_span, int),
                "labels": np.array([m.label for m in self.modes], dtype=str),
                "family": np.array([m.family for m in self.modes], dtype=str),
                "frequency_hz": np.array([m.frequency_hz for m in self.modes], float),
                "shape": shape}

    def find(self, label: str) -> Mode:
        """The mode with a label such as ``"TS1"``.

        Parameters
        ----------
        label : str
            A mode label (``"VS1"``, ``"TA2"``, ...).

        Returns
        -------
        Mode
            That mode (label, family, frequency [Hz], ...).

        Raises
        ------
        BridgeflapError
            No mode has that label.
        """
        for m in self.modes:
            if m.label == label:
                return m
        raise BridgeflapError(f"no mode {label} in the computed set")

    def structural_basis(self, count: int) -> StructuralBasis:
        """The lowest ``count`` vertical and torsional modes as generalised coordinates.

        Mass-normalised: ``M = I``, ``K = diag(omega^2)``, ``C = diag(2 zeta omega)`` (Rayleigh
        damping is diagonal in the modes). Lateral modes are not coupled by thin-aerofoil
        loads (lift and moment only) and are left out of the aeroelastic state.

        Parameters
        ----------
        count : int
            The vertical and torsional modes kept (the lowest, by frequency), at least 1.

        Returns
        -------
        StructuralBasis
            ``M``, ``C``, ``K`` (count x count), the strip mode shapes ``phi_h`` [m] and
            ``phi_a`` [rad], the strip lengths and positions [m] and the mode labels.

        Raises
        ------
        BridgeflapInputError
            ``modes``: ``count`` below 1 or above the model's vertical and torsional modes.
        """
        cand = [i for i, m in enumerate(self.modes) if m.family in ("vertical", "torsional")]
        if count < 1:
            raise BridgeflapInputError("modes", f"at least one mode is needed, got {count}")
        if count > len(cand):
            raise BridgeflapInputError("modes", f"{count} requested, but this model has only "
                                                f"{len(cand)} vertical and torsional modes")
        chosen = cand[:count]
        n_strip = len(self.structure.strip_x)
        phi_h = np.zeros((n_strip, len(chosen)))
        phi_a = np.zeros((n_strip, len(chosen)))
        omega = np.zeros(len(chosen))
        zeta = np.zeros(len(chosen))
        for j, i in enumerate(chosen):
            m = self.modes[i]
            v = self.shape(i)
            fam = self.structure.families[m.family]
            if m.family == "vertical":
                phi_h[:, j] = fam.strip_map @ v
            else:
                phi_a[:, j] = fam.strip_map @ v
            omega[j] = 2 * np.pi * m.frequency_hz
            zeta[j] = m.damping_ratio
        st = self.structure
        return StructuralBasis(
            M=np.eye(len(chosen)), C=np.diag(2 * zeta * omega), K=np.diag(omega ** 2),
            phi_h=phi_h, phi_a=phi_a, strip_length=st.strip_length,
            strip_x=st.global_x(st.strip_span, st.strip_x),
            labels=tuple(self.modes[i].label for i in chosen))

    def shape(self, i: int) -> np.ndarray:
        """Mass-normalised eigenvector (family DOFs) of ``modes[i]``.

        Parameters
        ----------
        i : int
            Index of the mode in ``modes`` (sorted by frequency).

        Returns
        -------
        numpy.ndarray
            The eigenvector on its family's degrees of freedom (mass-normalised).
        """
        m = self.modes[i]
        return self.shapes[m.family][:, self.family_index[m.family].index(i)]

    def plot(self, labels=None, ax=None, per_family: int = 3):
        """Mode shapes along the bridge, one panel per family (vertical, torsional, lateral),
        towers marked: the lowest ``per_family`` of each family, or the modes named in
        ``labels`` (:func:`bridgeflap.model.structure.plots.mode_shapes_by_family`; ``ax``: one axis
        per family).

        Parameters
        ----------
        labels : sequence of str, optional
            Modes to draw (default: the lowest ``per_family`` of each family).
        ax : sequence of matplotlib.axes.Axes, optional
            One axes per family (default: a new figure).
        per_family : int, default 3
            Modes drawn per family when ``labels`` is not given.

        Returns
        -------
        matplotlib.figure.Figure
            The figure drawn on (a new one when no axes are given).
        """
        from bridgeflap.model.structure.plots import mode_shapes_by_family

        return mode_shapes_by_family(self, per_family, ax, labels)


def _span_of(structure: StructuralModel, node_field: np.ndarray) -> str:
    """Name of the span holding the largest share of the nodal norm."""
    shares = [float(np.sum(node_field[structure.node_span == s] ** 2))
              for s in range(len(structure.spec.spans))]
    return structure.spec.spans[int(np.argmax(shares))].name if max(shares) > 0 else "main"


def _symmetry(structure: StructuralModel, node_field: np.ndarray) -> tuple[str, float]:
    """Symmetric/antisymmetric about the main-span mid-point, and the main-span share.

    For modes living in a side span the main-span part is tiny and the sign of the
    correlation is not meaningful; such modes are labelled by their span instead.
    """
    m = structure.main_span
    sel = structure.node_span == m
    x = structure.node_x[sel]
    y = node_field[sel]
    L = structure.spec.main_span.length_m
    mirrored = np.interp(L - x, x, y)
    corr = float(np.dot(y, mirrored))
    total = float(np.sum(node_field ** 2))
    share = float(np.sum(y ** 2) / total) if total > 0 else 0.0
    return ("symmetric" if corr >= 0 else "antisymmetric"), share


def solve(structure: StructuralModel, count: int | None = None) -> ModalModel:
    """Eigen-solution of every family, labels and Rayleigh damping.

    Parameters
    ----------
    structure : StructuralModel
    count : int, optional
        Keep the lowest ``count`` modes of each family (all when omitted).

    An imported modal bridge's structure
    (:class:`bridgeflap.model.structure.modal_import.ImportedStructure`) gives its
    :class:`bridgeflap.model.structure.modal_import.ImportedModalModel`, which has the same
    interface.
    """
    imported = getattr(structure, "modal_model", None)
    if imported is not None:
        return imported(count)
    raw = []
    shapes = {}
    for name, fam in structure.families.items():
        w2, vec = sla.eigh(fam.K, fam.M)
        if np.any(w2 <= 0):
            raise BridgeflapError(f"{name} stiffness is not positive definite "
                                  f"(min eigenvalue {w2.min():.3g})")
        if count is not None:
            w2, vec = w2[:count], vec[:, :count]
        shapes[name] = vec
        for j in range(len(w2)):
            field_ = fam.node_map @ vec[:, j]
            sym, share = _symmetry(structure, field_)
            span = "main" if share >= 0.5 else _span_of(structure, field_)
            if span == structure.spec.main_span.name:
                span = "main"
            deck_share = 1.0
            v = vec[:, j]
            if fam.M_deck is not None:  # deck and cables on the same DOFs
                deck_share = float(v @ fam.M_deck @ v / (v @ fam.M @ v))
            if fam.deck_mask is not None:
                md = fam.deck_mask
                deck_share = float(v[md] @ fam.M[np.ix_(md, md)] @ v[md] / (v @ fam.M @ v))
            raw.append((float(np.sqrt(w2[j])), name, sym, share, j, deck_share, span))
    first_v = min(r[0] for r in raw if r[1] == "vertical")
    first_t = min(r[0] for r in raw if r[1] == "torsional")
    a_m, a_k = rayleigh_coefficients(first_v, first_t, structure.spec.damping.ratio)
    raw.sort(key=lambda r: r[0])
    counters: dict = {}
    modes, col_of = [], []
    for w, name, sym, share, j, deck_share, span in raw:
        key = (name, sym) if span == "main" else (name, span)
        counters[key] = counters.get(key, 0) + 1
        zeta = a_m / (2 * w) + a_k * w / 2
        modes.append(Mode(name, sym, w / (2 * np.pi), float(zeta), counters[key], share,
                          deck_share, span))
        col_of.append((name, j))
    # family_index[name][col] = index in modes of that family's eigenvector column col
    family_index = {}
    for name in structure.families:
        cols = sorted((j, i) for i, (n, j) in enumerate(col_of) if n == name)
        family_index[name] = [i for _, i in cols]
    return ModalModel(structure=structure, modes=tuple(modes), shapes=shapes,
                      family_index=family_index, rayleigh=(a_m, a_k))


def rayleigh_coefficients(omega1: float, omega2: float, zeta: float) -> tuple[float, float]:
    """``(a_M, a_K)`` giving ratio ``zeta`` at ``omega1`` and ``omega2`` [rad/s]."""
    if abs(omega1 - omega2) < 1e-12 * omega1:
        return 2 * zeta * omega1, 0.0
    a_k = 2 * zeta / (omega1 + omega2)
    a_m = a_k * omega1 * omega2
    return float(a_m), float(a_k)


def modal_model(spec: BridgeSpec, count: int | None = None) -> ModalModel:
    """Convenience: statics, assembly and modes of ``spec`` in one call."""
    return solve(assemble(spec), count)
