"""The modal model of an imported bridge: strips, modes and the structural basis.

:class:`ImportedStructure` is what :func:`bridgeflap.model.structure.fe.assemble` returns for a
bridge with ``[structure] kind = "modal"`` (:mod:`bridgeflap.model.structure.modal_import`), and
:class:`ImportedModalModel` what :func:`bridgeflap.model.structure.modes.solve` makes of it: the
interface of
:class:`bridgeflap.model.structure.modes.ModalModel` (``modes``, ``table``, ``find``,
``structural_basis``, ``plot``). docs/modal_import.md.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from bridgeflap.model.aero.basis import StructuralBasis
from bridgeflap.model.errors import BridgeflapError, BridgeflapInputError
from bridgeflap.model.structure.modal_files import needs_fe as _needs_fe
from bridgeflap.model.structure.mode import Mode

__all__ = ["ImportedModalModel", "ImportedStructure", "compare_modes", "imported_structure"]


# ----------------------------------------------------------------------- the modal model


@dataclass(frozen=True)
class ImportedStructure:
    """What :func:`bridgeflap.model.structure.fe.assemble` returns for a modal bridge: the strips
    and the data.

    FE-only attributes (``statics``, ``families``, ``elements``) raise one-line input errors.
    """

    spec: object
    strip_x: np.ndarray          # [m] from the start of the first deck segment
    strip_length: np.ndarray     # [m]

    @property
    def main_span(self) -> int:
        """Index of the main span (of :attr:`spec`'s spans)."""
        return self.spec.main_span_index

    def global_x(self, span, x):
        """Identity on strip positions (they are already measured along the whole deck)."""
        return np.asarray(x)

    @property
    def statics(self):
        """Refused: cable statics need the cable model."""
        raise _needs_fe(self.spec.name, "cable statics")

    @property
    def families(self):
        """Refused: FE matrices need the FE model."""
        raise _needs_fe(self.spec.name, "the FE matrices")

    @property
    def elements(self):
        """Refused: the FE mesh needs the FE model."""
        raise _needs_fe(self.spec.name, "the FE mesh")

    def modal_model(self, count: int | None = None) -> ImportedModalModel:
        """The :class:`ImportedModalModel` (lowest ``count`` modes of each family)."""
        return _modal_model(self, count)


def imported_structure(spec) -> ImportedStructure:
    """The strips of a :class:`ModalBridgeSpec` (the :func:`bridgeflap.model.structure.fe.assemble`
    hook)."""
    sx, sl = spec.structure.strips()
    return ImportedStructure(spec=spec, strip_x=sx - spec.structure.deck_segments_m[0][0],
                             strip_length=sl)


@dataclass(frozen=True)
class ImportedModalModel:
    """An imported modal model with the interface of
    :class:`bridgeflap.model.structure.modes.ModalModel`.

    Attributes
    ----------
    modes : tuple of bridgeflap.model.structure.modes.Mode
        Sorted by frequency; labels from the file, else ``VS1``-style from the shapes.
    order : tuple of int
        Column of :attr:`ModalStructure.data` of each entry of ``modes``.
    strip_shapes : dict
        ``family -> (n_strip, n_m)`` in file column order.
    mass_check : list of dict
        :meth:`ModalStructure.mass_check`.
    """

    structure: ImportedStructure
    modes: tuple
    order: tuple
    strip_shapes: dict
    mass_check: list

    @property
    def spec(self):
        """The bridge definition."""
        return self.structure.spec

    @property
    def rayleigh(self):
        """Refused: an imported model carries its damping ratios per mode."""
        raise _needs_fe(self.spec.name, "Rayleigh damping coefficients")

    def mode_records(self) -> list[dict]:
        """Modes as JSON-ready dicts, sorted by frequency (the rows of :meth:`table`)."""
        return [m.as_dict() for m in self.modes]

    def to_dataframe(self):
        """The modes as a :class:`pandas.DataFrame` (one row per mode, unit-named columns)."""
        import pandas as pd

        return pd.DataFrame(self.mode_records())

    def table(self, fmt: str = "github") -> str:
        """:meth:`to_dataframe` as text (``fmt``: any :mod:`tabulate` format)."""
        from bridgeflap.model.results import table_text

        return table_text(self.to_dataframe(), fmt)

    def find(self, label: str):
        """The mode with a label such as ``"TS1"``."""
        for m in self.modes:
            if m.label == label:
                return m
        raise BridgeflapError(f"no mode {label} in the imported set")

    def structural_basis(self, count: int) -> StructuralBasis:
        """The lowest ``count`` vertical and torsional modes as generalised coordinates.

        ``M = diag(M_j)``, ``K = diag(M_j omega_j^2)``, ``C = diag(2 zeta_j omega_j M_j)``
        with the generalised masses ``M_j`` (1 for mass-normalised shapes, which then gives
        exactly the FE path's basis); lateral modes are left out as in the FE path.
        """
        if count < 1:
            raise BridgeflapInputError("modes", f"at least one mode is needed, got {count}")
        d = self.structure.spec.structure.data
        chosen = [i for i, m in enumerate(self.modes)
                  if m.family in ("vertical", "torsional")][:count]
        cols = [self.order[i] for i in chosen]
        gm = d.generalised_mass[cols]
        omega = 2 * np.pi * np.array([self.modes[i].frequency_hz for i in chosen])
        zeta = np.array([self.modes[i].damping_ratio for i in chosen])
        st = self.structure
        return StructuralBasis(
            M=np.diag(gm), C=np.diag(2 * zeta * omega * gm), K=np.diag(gm * omega ** 2),
            phi_h=self.strip_shapes["vertical"][:, cols],
            phi_a=self.strip_shapes["torsional"][:, cols],
            strip_length=st.strip_length, strip_x=st.strip_x,
            labels=tuple(self.modes[i].label for i in chosen))

    def derivative_basis(self, count: int, lateral: bool = True) -> tuple:
        """``(basis, phi_p)`` for flutter-derivative loads
        (:mod:`bridgeflap.model.aeroelastic.derivative_system`).

        With ``lateral`` and lateral shapes in the file: the lowest ``count`` modes of all
        families together (lateral modes included, since the drag derivatives act on them)
        and ``phi_p`` ``(n_strip, n)`` the strip lateral displacement [m, the file's y] of
        each coordinate (the torsional modes' lateral components included). Otherwise
        :meth:`structural_basis` and ``None``.
        """
        if not lateral or "lateral" not in self.strip_shapes:
            return self.structural_basis(count), None
        if count < 1:
            raise BridgeflapInputError("modes", f"at least one mode is needed, got {count}")
        d = self.structure.spec.structure.data
        chosen = list(range(len(self.modes)))[:count]
        cols = [self.order[i] for i in chosen]
        gm = d.generalised_mass[cols]
        omega = 2 * np.pi * np.array([self.modes[i].frequency_hz for i in chosen])
        zeta = np.array([self.modes[i].damping_ratio for i in chosen])
        st = self.structure
        basis = StructuralBasis(
            M=np.diag(gm), C=np.diag(2 * zeta * omega * gm), K=np.diag(gm * omega ** 2),
            phi_h=self.strip_shapes["vertical"][:, cols],
            phi_a=self.strip_shapes["torsional"][:, cols],
            strip_length=st.strip_length, strip_x=st.strip_x,
            labels=tuple(self.modes[i].label for i in chosen))
        return basis, self.strip_shapes["lateral"][:, cols]

    def plot(self, labels=None, ax=None, per_family: int = 3):
        """Mode shapes by family (as :meth:`bridgeflap.model.structure.modes.ModalModel.plot`);
        returns the Figure."""
        from bridgeflap.model.results import figure_of

        return figure_of(self._plot_axes(labels, ax, per_family))

    def _plot_axes(self, labels=None, ax=None, per_family: int = 3):
        """Imported deck shapes, one panel per family, the main-span ends marked
        (:func:`bridgeflap.model.structure.plots.imported_mode_shapes`)."""
        from bridgeflap.model.structure.plots import imported_mode_shapes

        return imported_mode_shapes(self, per_family, ax, labels)


def _symmetry(x, y, span) -> tuple[str, float]:
    """Symmetric/antisymmetric about the main-span mid-point, and the main-span share."""
    a, b = span
    sel = (x >= a - 1e-9) & (x <= b + 1e-9)
    total = float(np.trapezoid(y ** 2, x))
    if sel.sum() < 2 or total <= 0:
        return "symmetric", 0.0
    xs, ys = x[sel], y[sel]
    corr = float(np.dot(ys, np.interp(a + b - xs, xs, ys)))
    share = float(np.trapezoid(ys ** 2, xs)) / total
    return ("symmetric" if corr >= 0 else "antisymmetric"), share


def _modal_model(st: ImportedStructure, count: int | None) -> ImportedModalModel:
    ms = st.spec.structure
    d = ms.data
    fams = ms.families()
    order = sorted(range(d.n_modes), key=lambda j: (float(d.frequency_hz[j]), j))
    if count is not None:
        seen: dict = {}
        kept = []
        for j in order:
            seen[fams[j]] = seen.get(fams[j], 0) + 1
            if seen[fams[j]] <= count:
                kept.append(j)
        order = kept
    counters: dict = {}
    modes = []
    for j in order:
        sym, share = _symmetry(d.station_x_m, d.shapes[fams[j]][:, j], ms.main_span_m)
        counters[(fams[j], sym)] = counters.get((fams[j], sym), 0) + 1
        label = d.labels[j] if d.labels and d.labels[j] else ""
        mode = Mode(fams[j], sym, float(d.frequency_hz[j]), float(d.damping_ratio[j]),
                    counters[(fams[j], sym)], share)
        if label and label != mode.label:
            mode = _LabelledMode(**dataclasses.asdict(mode), given_label=label)
        modes.append(mode)
    labels = [m.label for m in modes]
    dup = sorted({lab for lab in labels if labels.count(lab) > 1})
    if dup:
        raise BridgeflapInputError("structure.label", f"duplicate mode label {dup[0]!r}")
    return ImportedModalModel(structure=st, modes=tuple(modes), order=tuple(order),
                              strip_shapes=ms.strip_shapes(), mass_check=ms.mass_check())


@dataclass(frozen=True)
class _LabelledMode(Mode):
    """A mode whose label comes from the imported file."""

    given_label: str = ""

    @property
    def label(self) -> str:
        """The file's label."""
        return self.given_label


def compare_modes(modal, reference, share_min: float = 0.5) -> list[dict]:
    """Pair the main-span modes of two modal models by (family, symmetry, order) and compare.

    Main-span modes (``main_span_share > share_min``) of each model, in frequency order
    within (family, symmetry); the ``k``-th of one is paired with the ``k``-th of the other.
    Rows: ``label`` (the reference's main-span label, e.g. ``VA2`` for the second main-span
    antisymmetric vertical mode), ``reference_hz``, ``model_hz``, ``ratio`` (model/reference),
    ``model_label``. Modes without a partner are left out.
    """
    def main_modes(mm):
        out: dict = {}
        for m in sorted(mm.modes, key=lambda m: m.frequency_hz):
            if m.main_span_share > share_min:
                out.setdefault((m.family, m.symmetry), []).append(m)
        return out

    ours, ref = main_modes(modal), main_modes(reference)
    rows = []
    for key, rmodes in ref.items():
        for k, r in enumerate(rmodes):
            mine = ours.get(key, [])
            if k >= len(mine):
                continue
            label = f"{key[0][0].upper()}{key[1][0].upper()}{k + 1}"
            rows.append({"label": label, "family": key[0], "symmetry": key[1],
                         "reference_hz": r.frequency_hz, "model_hz": mine[k].frequency_hz,
                         "ratio": mine[k].frequency_hz / r.frequency_hz,
                         "model_label": mine[k].label})
    return sorted(rows, key=lambda r: r["reference_hz"])
