"""Ritz projection: a perturbed structure on the nominal mode shapes (the one projection).

With ``Phi`` the retained mass-normalised nominal modes of each family (vertical, torsional; the
families are uncoupled), a structure with changed parameters is represented by
``M_r = Phi^T M(p) Phi``, ``K_r = Phi^T K(p) Phi`` and the strip maps of ``Phi``. Holding the
basis fixed avoids the sign flips and re-ordering of re-solved modes; at the nominal point the
projection *is* the nominal modal model. Used by the symbolic ``A(U, p)``
(:mod:`bridgeflap.model.aeroelastic.symbolic`) and by the implicit-function sensitivities
(:mod:`bridgeflap.design.sensitivity.local`).
"""

from __future__ import annotations

import numpy as np
import scipy.linalg as sla

from bridgeflap.model.aero.basis import StructuralBasis
from bridgeflap.model.errors import BridgeflapError
from bridgeflap.model.structure.fe import assemble
from bridgeflap.model.structure.modes import ModalModel, rayleigh_coefficients
from bridgeflap.model.structure.spec import BridgeSpec

__all__ = ["chosen_modes", "first_frequency", "ritz_basis"]

AEROELASTIC_FAMILIES = ("vertical", "torsional")


def chosen_modes(modal: ModalModel, n_modes: int) -> list[int]:
    """Indices of the retained modes, as
    :meth:`bridgeflap.model.structure.modes.ModalModel.structural_basis`."""
    cand = [i for i, m in enumerate(modal.modes) if m.family in AEROELASTIC_FAMILIES]
    return cand[:int(n_modes)]


def first_frequency(family) -> float:
    """Lowest natural circular frequency [rad/s] of an FE family."""
    w2 = sla.eigh(family.K, family.M, eigvals_only=True, subset_by_index=[0, 0])[0]
    return float(np.sqrt(w2))


def ritz_basis(spec: BridgeSpec, nominal: ModalModel, n_modes: int,
               erection_gj_factor: float = 0.5, shape_offset: dict | None = None,
               ) -> StructuralBasis:
    """Structural basis of ``spec`` projected on the nominal mode shapes (Ritz).

    Parameters
    ----------
    spec : BridgeSpec
        Perturbed bridge (same mesh as ``nominal``).
    nominal : ModalModel
        Nominal modal model; its lowest ``n_modes`` vertical and torsional shapes are the basis.
    n_modes : int
        Retained coordinates, chosen as in :meth:`ModalModel.structural_basis`.
    erection_gj_factor : float
        Deck GJ factor of an erection stage [-] (as :func:`bridgeflap.model.structure.fe.assemble`).
    shape_offset : dict, optional
        Family -> (n_dof, n_family) added to the nominal shapes (moved basis).

    Notes
    -----
    ``M_r = Phi^T M(p) Phi`` and ``K_r = Phi^T K(p) Phi`` per family, Rayleigh damping
    ``C_r = a_M M_r + a_K K_r`` with ``(a_M, a_K)`` from the perturbed first vertical and
    torsional frequencies of the full FE families (as :func:`bridgeflap.model.structure.modes.solve`
    does). At ``spec == nominal.spec`` this reproduces ``nominal.structural_basis(n_modes)``.
    """
    if getattr(spec, "structure", None) is not None:  # imported modes: nothing to project
        return nominal.structural_basis(n_modes)      # (a modal bridge varies aero inputs only)
    structure = assemble(spec, erection_gj_factor=erection_gj_factor)
    chosen = chosen_modes(nominal, n_modes)
    n = len(chosen)
    n_strip = len(structure.strip_x)
    if n_strip != len(nominal.structure.strip_x):
        raise BridgeflapError("the perturbation changes the mesh: no fixed Ritz basis")
    M, K = np.zeros((n, n)), np.zeros((n, n))
    phi_h, phi_a = np.zeros((n_strip, n)), np.zeros((n_strip, n))
    for family, target in (("vertical", phi_h), ("torsional", phi_a)):
        cols = [j for j, i in enumerate(chosen) if nominal.modes[i].family == family]
        if not cols:
            continue
        Phi = np.column_stack([nominal.shape(chosen[j]) for j in cols])
        if shape_offset is not None:
            Phi = Phi + shape_offset[family]
        fam = structure.families[family]
        if fam.M.shape[0] != Phi.shape[0]:
            raise BridgeflapError("the perturbation changes the mesh: no fixed Ritz basis")
        ix = np.ix_(cols, cols)
        M[ix] = Phi.T @ fam.M @ Phi
        K[ix] = Phi.T @ fam.K @ Phi
        target[:, cols] = fam.strip_map @ Phi
    a_m, a_k = rayleigh_coefficients(first_frequency(structure.families["vertical"]),
                                     first_frequency(structure.families["torsional"]),
                                     spec.damping.ratio)
    M, K = 0.5 * (M + M.T), 0.5 * (K + K.T)
    return StructuralBasis(M=M, C=a_m * M + a_k * K, K=K, phi_h=phi_h, phi_a=phi_a,
                           strip_length=structure.strip_length,
                           strip_x=structure.global_x(structure.strip_span, structure.strip_x),
                           labels=tuple(nominal.modes[i].label for i in chosen))
