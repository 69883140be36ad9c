"""Rigid two-degree-of-freedom deck section (heave and pitch) on the same machinery.

Used by engineers for quick checks (``bridgeflap section``) and by the tests (Hodges & Pierce
typical section, docs/humber_data.md#hodges-and-pierce-typical-section). The structure is written in
mid-chord coordinates ``q = (h_mid, alpha)`` so that the bridge's strip aerodynamics
(:mod:`bridgeflap.model.aero.strips`) applies unchanged; an elastic axis at ``a b`` (Theodorsen's
``a``, semichords aft of mid-chord) and a centre of gravity ``x_theta b`` aft of it are handled by
the transformation ``h_ea = h_mid + a b alpha``.
"""

from __future__ import annotations

import numpy as np

from bridgeflap.model.aero.basis import StructuralBasis
from bridgeflap.model.arguments import checked, number
from bridgeflap.model.errors import BridgeflapInputError


def _pos(name, v):
    if not (isinstance(v, int | float) and np.isfinite(v) and v > 0):
        raise BridgeflapInputError(name, f"must be a positive number, got {v!r}")


#: a positive physical quantity: mass, inertia, density, ratios of them
_POSITIVE = number(0.0, 1.0e9, strict=True)


@checked(mass_kg_per_m=_POSITIVE, inertia_kgm2_per_m=_POSITIVE,
         f_heave_hz=number(0.0, 1.0e3, strict=True), f_torsion_hz=number(0.0, 1.0e3, strict=True),
         half_chord_m=number(0.0, 1.0e3, strict=True), damping_ratio=number(0.0, 1.0),
         elastic_axis_a=number(-1.0, 1.0), x_theta=number(-1.0e3, 1.0e3))
def section_basis(mass_kg_per_m: float, inertia_kgm2_per_m: float, f_heave_hz: float,
                  f_torsion_hz: float, half_chord_m: float, damping_ratio: float = 0.0,
                  elastic_axis_a: float = 0.0, x_theta: float = 0.0) -> StructuralBasis:
    """Structural basis of a unit-length section.

    Parameters
    ----------
    mass_kg_per_m : float
        Mass per length [kg/m].
    inertia_kgm2_per_m : float
        Mass moment of inertia about the elastic axis [kg m^2/m].
    f_heave_hz, f_torsion_hz : float
        Uncoupled natural frequencies [Hz]: ``sqrt(k_h/m)`` and ``sqrt(k_alpha/I)``.
    half_chord_m : float
        ``b`` [m].
    damping_ratio : float
        Structural damping ratio of each uncoupled DOF [-].
    elastic_axis_a : float
        Elastic-axis position in semichords aft of mid-chord [-] (Theodorsen's ``a``).
    x_theta : float
        Centre of gravity aft of the elastic axis, in semichords [-].

    Returns
    -------
    StructuralBasis
        Mass, stiffness and damping of the two degrees of freedom (heave [m], pitch [rad]), the
        input of the section's aeroelastic model.
    """
    for name, v in (("mass_kg_per_m", mass_kg_per_m), ("inertia_kgm2_per_m", inertia_kgm2_per_m),
                    ("f_heave_hz", f_heave_hz), ("f_torsion_hz", f_torsion_hz),
                    ("half_chord_m", half_chord_m)):
        _pos(name, v)
    if not (np.isfinite(damping_ratio) and 0 <= damping_ratio < 1):
        raise BridgeflapInputError("damping_ratio", f"must be in [0, 1), got {damping_ratio}")
    if not -1 < elastic_axis_a < 1:
        raise BridgeflapInputError("elastic_axis_a", "must lie inside the chord (-1, 1)")
    m, inertia, b = float(mass_kg_per_m), float(inertia_kgm2_per_m), float(half_chord_m)
    s = m * x_theta * b
    if inertia <= s * s / m:
        raise BridgeflapInputError("inertia_kgm2_per_m",
                                   "mass matrix not positive definite for this x_theta")
    wh, wa = 2 * np.pi * f_heave_hz, 2 * np.pi * f_torsion_hz
    M_ea = np.array([[m, s], [s, inertia]])
    K_ea = np.diag([m * wh ** 2, inertia * wa ** 2])
    C_ea = np.diag([2 * damping_ratio * m * wh, 2 * damping_ratio * inertia * wa])
    T = np.array([[1.0, elastic_axis_a * b], [0.0, 1.0]])
    return StructuralBasis(M=T.T @ M_ea @ T, C=T.T @ C_ea @ T, K=T.T @ K_ea @ T,
                           phi_h=np.array([[1.0, 0.0]]), phi_a=np.array([[0.0, 1.0]]),
                           strip_length=np.array([1.0]), strip_x=np.array([0.0]),
                           labels=("heave", "pitch"))


@checked(mu=_POSITIVE, r2=_POSITIVE, sigma=_POSITIVE, a=number(-1.0, 1.0),
         x_theta=number(-1.0e3, 1.0e3),
         half_chord_m=number(0.0, 1.0e3, strict=True), omega_theta=_POSITIVE,
         air_density=_POSITIVE)
def typical_section(mu: float, r2: float, sigma: float, a: float, x_theta: float,
                    half_chord_m: float = 1.0, omega_theta: float = 1.0,
                    air_density: float = 1.0) -> StructuralBasis:
    """Hodges & Pierce nondimensional typical section
    (docs/humber_data.md#hodges-and-pierce-typical-section).

    ``mu = m / (pi rho b^2)``, ``r2 = I_ea / (m b^2)``, ``sigma = omega_h / omega_theta``.

    Parameters
    ----------
    mu : float
        Mass ratio ``m / (pi rho b^2)`` [-].
    r2 : float
        Squared radius of gyration ``I_ea / (m b^2)`` [-].
    sigma : float
        Frequency ratio ``omega_h / omega_theta`` [-].
    a : float
        Elastic axis aft of mid-chord in semichords [-].
    x_theta : float
        Centre of gravity aft of the elastic axis in semichords [-].
    half_chord_m : float, default 1.0
        ``b`` [m].
    omega_theta : float, default 1.0
        Torsional frequency [rad/s].
    air_density : float, default 1.0
        ``rho`` [kg/m^3].

    Returns
    -------
    StructuralBasis
        The section's structural matrices.
    """
    b = half_chord_m
    m = mu * np.pi * air_density * b * b
    inertia = r2 * m * b * b
    return section_basis(m, inertia, sigma * omega_theta / (2 * np.pi),
                         omega_theta / (2 * np.pi), b, 0.0, a, x_theta)
