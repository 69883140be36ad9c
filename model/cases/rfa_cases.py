"""The flat-plate flutter cases on which a Theodorsen RFA (:mod:`bridgeflap.model.aero.rfa`) is
checked.

Each case is solved twice on the same structure and strip loads: by the RFA state space
(:func:`bridgeflap.model.stability.sweeps.sweep`) and by the exact-Theodorsen p-k
(:func:`bridgeflap.model.stability.sweeps.pk_sweep`), so the gap between the two flutter speeds is
the RFA's own error. Cases:

============== =================================================================================
``hp-1``       Hodges & Pierce typical section (a = -1/5, e = -1/10, mu = 20, r^2 = 6/25,
               sigma = 2/5; tests/test_aeroelastic.py), non-dimensional: b = 1, omega_theta = 1,
               rho = 1, speeds in ``U / (b omega_theta)``
``hp-2``       the same with a = -1/3, mu = 50, r^2 = 4/25
``section``    the Humber-like 2-DOF section of the golden cases (7660 kg/m, 3.75e5 kg m^2/m,
               0.117 / 0.311 Hz, b = 11 m, rho = 1.225 kg/m^3; ``bridgeflap section``)
``iabse-1.1a`` IABSE TG3.1 step 1.1a structure
(:func:`bridgeflap.model.cases.section_cases.load_section_case`),
               flat plate in its own convention (no apparent-inertia moment), b = 15.5 m
``iabse-1.1a-ai`` the same with the apparent-inertia moment kept (the package default)
``iabse-2a``   IABSE step 2a bridge (model/bridges/iabse/step2a_bridge.toml, 9 modes, flat
               plate): the one multi-mode case on the Theodorsen strip path
============== =================================================================================

IABSE 1.1c is not a separate case: its heave and pitch masses, stiffnesses, damping, chord and
air density are those of 1.1a, so its flat-plate problem is 1.1a's; what differs (the measured
PoliMi tables and the lateral DOF) is fitted by a Roger RFA of the tables
(:func:`bridgeflap.model.aero.derivatives.fit_roger`), not by :mod:`bridgeflap.model.aero.rfa`.
Conventions: :mod:`bridgeflap.model`.
"""

from __future__ import annotations

import numpy as np

from bridgeflap.model.errors import BridgeflapInputError

__all__ = ["RFA_CHECK_CASES", "case_system", "flutter_gap"]

RFA_CHECK_CASES: tuple[str, ...] = ("hp-1", "hp-2", "section", "iabse-1.1a", "iabse-1.1a-ai",
                                    "iabse-2a")
"""Names accepted by :func:`case_system` and :func:`flutter_gap`."""

#: Hodges & Pierce sections (a, e, mu, r^2, sigma): as tests/test_aeroelastic.py HP_CASES
_HP = {"hp-1": (-1 / 5, -1 / 10, 20.0, 6 / 25, 2 / 5),
       "hp-2": (-1 / 3, -1 / 10, 50.0, 4 / 25, 2 / 5)}


def case_system(name: str, rfa="rfa4"):
    """``(system, rfa_speeds, pk_speeds, speed_tol, half_chord_m)`` of an RFA check case.

    Parameters
    ----------
    name : str
        One of :data:`RFA_CHECK_CASES`.
    rfa : str or RationalApprox
        The approximation of ``C(k)`` of the state space
        (:func:`bridgeflap.model.aero.rfa.get_rfa`).

    Returns
    -------
    tuple
        The :class:`bridgeflap.model.aeroelastic.statespace.AeroelasticSystem`, the speed grid of
        the RFA sweep and of the p-k continuation [m/s, or ``U / (b omega_theta)`` for ``hp-*``],
        the Brent tolerance on the crossing [same unit] and ``b`` [m].

    Raises
    ------
    BridgeflapInputError
        Unknown ``name``.
    """
    from bridgeflap.model.aeroelastic import statespace
    from bridgeflap.model.cases.section import section_basis, typical_section

    if name in _HP:
        a, e, mu, r2, sigma = _HP[name]
        basis = typical_section(mu, r2, sigma, a, e - a)
        grid = np.arange(0.0, 3.2 + 1e-9, 0.02)  # flutter at 2.18 / 2.79 (divergence above)
        return statespace.build(basis, 1.0, 1.0, rfa=rfa), grid, grid, 1e-9, 1.0
    if name == "section":
        basis = section_basis(7660.0, 375000.0, 0.117, 0.311, 11.0)
        grid = np.arange(0.0, 100.0 + 1e-9, 0.5)  # flutter 48.2 m/s, divergence 55.5 m/s
        return statespace.build(basis, 11.0, 1.225, rfa=rfa), grid, grid, 1e-7, 11.0
    if name in ("iabse-1.1a", "iabse-1.1a-ai"):
        from bridgeflap.model.cases.section_cases import load_section_case

        case = load_section_case("iabse-1.1a")
        b = 0.5 * case.derivatives.chord_m
        grid = np.arange(0.0, 150.0 + 1e-9, 1.0)  # flutter 77.5 m/s
        return (statespace.build(case.basis, b, case.air_density, rfa=rfa,
                                 added_inertia=name.endswith("-ai")), grid, grid, 1e-7, b)
    if name == "iabse-2a":
        from bridgeflap.model import analysis
        from bridgeflap.model.structure.loader import load_bridge

        spec = load_bridge("iabse-2a")
        _, system = analysis.bridge_system(spec, analysis.DEFAULT_MODES, rfa=rfa)
        # the CLI's 0-85 m/s grid; the p-k continuation on 2.5 m/s finds the same crossing
        return (system, np.arange(0.0, 85.0 + 1e-9, 0.5), np.arange(0.0, 85.0 + 1e-9, 2.5),
                1e-6, spec.deck.half_chord_m)
    raise BridgeflapInputError("case", f"unknown RFA check case {name!r}; expected one of "
                               f"{RFA_CHECK_CASES}")


def flutter_gap(name: str, rfas=("rfa4",)) -> dict:
    """Exact p-k and RFA flutter speeds of a case, and their relative gaps.

    Parameters
    ----------
    name : str
        One of :data:`RFA_CHECK_CASES`.
    rfas : sequence of str or RationalApprox
        Approximations to compare (names of :data:`bridgeflap.model.aero.rfa.RFA_NAMES`, or fits);
        each is reported under its ``name``.

    Returns
    -------
    dict
        JSON-ready: ``case``, ``half_chord_m``, ``exact_flutter_speed`` and
        ``exact_flutter_status`` (p-k, exact ``C(k)``), ``exact_reduced_frequency``
        (``k = omega b / U`` at flutter [-]), and per approximation under ``rfa[name]``:
        ``flutter_speed``, ``flutter_status``, ``gap_percent`` (``100 (U_rfa / U_exact - 1)``)
        and ``c_error_at_flutter`` (``|C_rfa(ik) - C(k)|`` at the exact flutter ``k`` [-]).
        Speeds in m/s, or ``U / (b omega_theta)`` for ``hp-*``.
    """
    from bridgeflap.model.aero.rfa import get_rfa
    from bridgeflap.model.aero.theodorsen import theodorsen
    from bridgeflap.model.stability import sweeps as stability

    fits = [get_rfa(r) if isinstance(r, str) else r for r in rfas]
    if not fits:
        raise BridgeflapInputError("rfas", "needs at least one approximation")
    system, u_rfa, u_pk, tol, b = case_system(name, fits[0])
    pk = stability.pk_sweep(system, u_pk, speed_tol=tol)
    ue = float(pk.flutter.speed)
    k_f = float(2 * np.pi * pk.flutter.frequency_hz * b / ue) if np.isfinite(ue) else np.nan
    out = {"case": name, "half_chord_m": float(b), "exact_flutter_speed": ue,
           "exact_flutter_status": pk.flutter.status, "exact_reduced_frequency": k_f, "rfa": {}}
    for i, approx in enumerate(fits):
        sys_r = system if i == 0 else case_system(name, approx)[0]
        sw = stability.sweep(sys_r, u_rfa, speed_tol=tol)
        u = float(sw.flutter.speed)
        c_err = (float(abs(approx.evaluate(k_f) - theodorsen(k_f))) if np.isfinite(k_f)
                 else float("nan"))
        out["rfa"][approx.name] = {"flutter_speed": u, "flutter_status": sw.flutter.status,
                         "gap_percent": float(100 * (u / ue - 1)) if np.isfinite(u / ue)
                         else float("nan"),
                         "c_error_at_flutter": c_err}
    return out
