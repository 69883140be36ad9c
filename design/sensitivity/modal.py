"""Sensitivities of the flutter and divergence speeds to imported modal data.

Parameters ``mode.<label>.<quantity>`` with ``quantity`` one of :data:`MODAL_QUANTITIES`: the
natural frequency ``f_j`` [Hz], the damping ratio ``zeta_j`` [-] or the generalised mass
``M_j`` [kg, or kg m^2 for a mode whose shape is in radians] of mode ``<label>`` of the
structural basis. The basis is diagonal (:mod:`bridgeflap.model.structure.modal_import`)::

    M = diag(M_j),  C = diag(2 zeta_j omega_j M_j),  K = diag(M_j omega_j^2),  omega_j = 2 pi f_j

with the mode shapes held: a change of ``M_j`` at fixed ``f_j`` scales the mode's inertia and
stiffness together against unchanged aerodynamic loads (a mass-ratio change). This is the
same model for a modal bridge (the shapes are data) and for the FE bridge's retained modes
(the modal quantities taken as inputs; the FE parameters themselves are
:func:`bridgeflap.design.sensitivity.local.local_sensitivity`'s).

The derivative is the implicit-function one of
:func:`bridgeflap.design.sensitivity.local.speed_derivative_ift` (``dU/dp = -(d Re lambda/dp) / (d
Re lambda/dU)``, ``dA/dp`` by a central difference of the state matrix rebuilt on the perturbed
basis, ``dA/dU = A1 + 2 U A2`` exact) on the bridge's own state space: Theodorsen
(:func:`bridgeflap.model.aeroelastic.statespace.spec_system`) or the flutter-derivative Roger state
space (:func:`bridgeflap.model.aeroelastic.derivative_system.derivative_system`, the same fit: the
RFA does not depend on the structure). The check is the central difference of the speed itself, both
points re-swept (``d_<q>_speed_fd``); the basis does not move with these inputs, so the
``fixed_basis`` and ``ritz_fd`` columns of the FE rows are the same numbers here.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence

import numpy as np

from bridgeflap.model.errors import BridgeflapError, BridgeflapInputError

__all__ = ["MODAL_QUANTITIES", "is_modal_parameter", "modal_sensitivity", "perturbed_basis"]

MODAL_QUANTITIES = ("frequency_hz", "damping_ratio", "generalised_mass")


def is_modal_parameter(path: str) -> bool:
    """``mode.<label>.<quantity>`` (syntax only; the label is checked against the basis)."""
    parts = str(path).split(".")
    return len(parts) == 3 and parts[0] == "mode" and bool(parts[1]) and \
        parts[2] in MODAL_QUANTITIES


def _modal_quantities(basis):
    gm = np.diag(basis.M).copy()
    omega = np.sqrt(np.diag(basis.K) / gm)
    zeta = np.diag(basis.C) / (2 * omega * gm)
    for name, mat in (("M", basis.M), ("K", basis.K), ("C", basis.C)):
        if np.any(np.abs(mat - np.diag(np.diag(mat))) > 1e-12 * np.abs(np.diag(mat)).max()):
            raise BridgeflapInputError("parameters", f"modal parameters need a diagonal {name} "
                                       "(uncoupled modes)")
    return gm, omega, zeta


def perturbed_basis(basis, label: str, quantity: str, value: float):
    """The basis with ``quantity`` of mode ``label`` set to ``value`` (module docstring)."""
    if label not in basis.labels:
        raise BridgeflapInputError("parameters", f"no mode {label!r} in the retained basis "
                                   f"({', '.join(basis.labels)})")
    j = basis.labels.index(label)
    gm, omega, zeta = _modal_quantities(basis)
    if quantity == "frequency_hz":
        omega[j] = 2 * np.pi * value
    elif quantity == "damping_ratio":
        zeta[j] = value
    else:
        gm[j] = value
    return dataclasses.replace(basis, M=np.diag(gm), K=np.diag(gm * omega ** 2),
                               C=np.diag(2 * zeta * omega * gm))


def _nominal_value(basis, label, quantity):
    gm, omega, zeta = _modal_quantities(basis)
    j = basis.labels.index(label)
    return float({"frequency_hz": omega[j] / (2 * np.pi), "damping_ratio": zeta[j],
                  "generalised_mass": gm[j]}[quantity])


def _system_factory(spec, n_modes: int):
    """``(basis0, make)``: the nominal basis and ``basis -> AeroelasticSystem`` of ``spec``."""
    from bridgeflap.model.aeroelastic import statespace
    from bridgeflap.model.analysis import bridge_system, modal_model

    modal = modal_model(spec)
    _, system0 = bridge_system(spec, n_modes, modal=modal)
    if getattr(spec, "derivatives", None) is None:
        return system0.basis, lambda b: statespace.spec_system(spec, b)
    from bridgeflap.model.aeroelastic.derivative_system import derivative_system

    phi_p, fit = system0.extras.get("phi_p"), system0.rfa
    source = system0.derivative_frozen.source
    rho = spec.aero.air_density_kg_m3
    return system0.basis, lambda b: derivative_system(b, source, rho, fit=fit, phi_p=phi_p)


def modal_sensitivity(spec, parameters: Sequence[str], speeds, n_modes: int, check: bool = True,
                      rel_step: float = 1e-4, fd_step: float = 1e-3,
                      progress: Callable[[str], None] | None = None, kink_step: float = 0.05):
    """IFT derivatives of ``U_F``, ``U_D`` to modal data, as a
    :class:`bridgeflap.design.sensitivity.ift.SensitivityResult` (same row keys)."""
    from bridgeflap.design.sensitivity.ift import (
        any_kink,
        critical_speeds,
        empty_entries,
        kink_entries,
        sensitivity_result,
        speed_derivative_ift,
    )
    from bridgeflap.model.stability.sweeps import oscillation_tolerance

    bad = [p for p in parameters if not is_modal_parameter(p)]
    if bad:
        raise BridgeflapInputError("parameters", f"{bad[0]!r}: modal parameters "
                                   "(mode.<label>.<quantity>) cannot be mixed with others")
    basis0, make = _system_factory(spec, int(n_modes))
    system0 = make(basis0)
    u = np.asarray(speeds, dtype=float)
    omega_tol = oscillation_tolerance(system0)
    crit = critical_speeds(system0, u)
    rows = []
    for path in parameters:
        _, label, quantity = path.split(".")
        if label not in basis0.labels:
            perturbed_basis(basis0, label, quantity, 0.0)  # raises, naming the retained modes
        p0 = _nominal_value(basis0, label, quantity)
        row: dict = {"parameter": path, "value": p0}
        for q in ("flutter", "divergence"):
            U, key = crit[f"{q}_speed_m_s"], f"d_{q}_speed"
            row.update(empty_entries(q, crit))
            if not np.isfinite(U):
                row[f"{q}_status"] = f"nominal {q}: {crit[f'{q}_status']}"
                continue
            try:
                def A_of_p(value, U=U, label=label, quantity=quantity):
                    return make(perturbed_basis(basis0, label, quantity, value)).A(U)

                d, diag = speed_derivative_ift(A_of_p, system0.A1 + 2 * U * system0.A2,
                                               system0.A(U), p0, q, omega_tol, rel_step)
            except BridgeflapError as exc:
                row[f"{q}_status"] = f"IFT failed: {exc}"
                continue
            row.update({key: d, f"{key}_fixed_basis": d, f"relative_{key}": p0 / U * d,
                        f"relative_{key}_fixed_basis": p0 / U * d,
                        f"{q}_re_lambda_at_crossing": diag["re_lambda"]})
        if check:
            h = fd_step * abs(p0)
            plus = critical_speeds(make(perturbed_basis(basis0, label, quantity, p0 + h)), u)
            minus = critical_speeds(make(perturbed_basis(basis0, label, quantity, p0 - h)), u)
            for q in ("flutter", "divergence"):
                k = f"{q}_speed_m_s"
                d = (plus[k] - minus[k]) / (2 * h)
                row.update({f"d_{q}_speed_fd": d, f"d_{q}_speed_ritz_fd": d,
                            f"relative_d_{q}_speed_fd": p0 / crit[k] * d,
                            f"{q}_fd_same_branch": (plus[f"{q}_branch_label"]
                                                    == minus[f"{q}_branch_label"]
                                                    == crit[f"{q}_branch_label"])})
            hk = kink_step * abs(p0)  # the kink check (local.local_sensitivity's)
            plus = critical_speeds(make(perturbed_basis(basis0, label, quantity, p0 + hk)), u)
            minus = critical_speeds(make(perturbed_basis(basis0, label, quantity, p0 - hk)), u)
            for q in ("flutter", "divergence"):
                row.update(kink_entries(q, p0, hk, crit, minus, plus, row[f"d_{q}_speed"]))
        row["kink"] = any_kink(row)
        rows.append(row)
        if progress:
            progress(path)
    return sensitivity_result(
        spec, crit, rows, n_modes,
        {"speeds_m_s": [float(u[0]), float(u[-1])], "rel_step_A": rel_step,
         "rel_step_fd": fd_step, "rel_step_kink": kink_step,
         "erected_fraction": spec.erected_fraction,
         "method": "IFT on the critical eigenvalue; dA/dp by central difference of A "
                   "rebuilt on the basis with the modal quantity changed (shapes "
                   "held); checked by the central difference of the speed"})
