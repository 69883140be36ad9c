"""Buffeting inputs: the state space and the gust-load model of
:func:`bridgeflap.model.response.buffeting.buffeting`.

The thin-aerofoil gust loads of the paper's Eq. (8) (vertical turbulence, ``C_L'`` and ``C_M'`` of
``spec.aero``; :func:`bridgeflap.model.aero.strips.strip_aero`) or the quasi-steady loads of the
bridge's ``[static_coefficients]`` (:mod:`bridgeflap.model.aero.quasi_steady`: ``u`` and ``w``), on
the Theodorsen state space or, for a bridge with flutter-derivative loads, on its Roger state space
(:func:`bridgeflap.model.aeroelastic.derivative_system.derivative_bridge_system`). The quasi-steady
input matrices are built by :func:`bridgeflap.model.aeroelastic.gust_input.quasi_steady_inputs`
(re-exported here). Conventions: :mod:`bridgeflap.model`.
"""

from __future__ import annotations

from bridgeflap.model.aeroelastic.gust_input import quasi_steady_inputs
from bridgeflap.model.errors import BridgeflapInputError

__all__ = ["LOADS", "quasi_steady_inputs", "resolve_system"]

#: gust-load models: the paper's Eq. (8) (w only, C_L' and C_M' slopes) or
#: model.aero.quasi_steady (u and w)
LOADS = ("thin-aerofoil", "quasi-steady")


def resolve_system(spec_or_system, n_modes, controller, spec, loads=None):
    """``(spec, system, basis, loads)`` from a bridge spec (open or closed loop) or a system.

    ``loads`` (None: ``"quasi-steady"`` for a flutter-derivative bridge, else
    ``"thin-aerofoil"``) chooses the gust loads; the quasi-steady ones
    (:mod:`bridgeflap.model.aero.quasi_steady`) replace ``Bw1`` by the ``w`` loads and put the ``u``
    loads in ``system.extras["Bw1_u"]``.
    """
    from bridgeflap.model.structure.spec import BridgeSpec

    if loads not in (None, *LOADS):
        raise BridgeflapInputError("loads", f"must be one of {LOADS}, got {loads!r}")
    if isinstance(spec_or_system, BridgeSpec):
        spec = spec_or_system
        der = getattr(spec, "derivatives", None) is not None
        loads = loads or ("quasi-steady" if der else "thin-aerofoil")
        if der and loads != "quasi-steady":
            raise BridgeflapInputError("loads", "this bridge's self-excited loads are "
                                       "flutter-derivative tables: its gust loads are the "
                                       "quasi-steady ones (--loads quasi-steady)")
        if loads == "quasi-steady" and getattr(spec, "static_coefficients", None) is None:
            raise BridgeflapInputError(
                "static_coefficients", f"bridge {spec.name!r} gives no [static_coefficients] "
                "(C_D, C_L, C_M and their slopes), which quasi-steady buffeting loads need")
        if controller is not None and loads == "quasi-steady":
            raise BridgeflapInputError("controller", "closed-loop buffeting is built for the "
                                       "thin-aerofoil gust loads only")
        if controller is not None:
            from bridgeflap.model.aeroelastic.flaps import closed_loop_system

            system = closed_loop_system(spec, controller, n_modes)
        elif der:
            from bridgeflap.model.aeroelastic.derivative_system import derivative_bridge_system
            from bridgeflap.model.structure.fe import assemble
            from bridgeflap.model.structure.modes import solve

            system = derivative_bridge_system(spec, solve(assemble(spec)), int(n_modes))
        else:
            from bridgeflap.model.aeroelastic import statespace
            from bridgeflap.model.structure.fe import assemble
            from bridgeflap.model.structure.modes import solve

            basis = solve(assemble(spec)).structural_basis(int(n_modes))
            system = statespace.spec_system(spec, basis)
        if loads == "quasi-steady":
            system = quasi_steady_inputs(system, spec)
        return spec, system, system.basis, loads
    system = spec_or_system
    if controller is not None:
        raise BridgeflapInputError("controller", "give a bridge spec with a controller")
    if loads == "quasi-steady":
        raise BridgeflapInputError("loads", "quasi-steady loads need a bridge spec")
    basis = getattr(system, "basis", None)
    if basis is None:
        raise BridgeflapInputError("system", "needs a .basis with strip_x (StructuralBasis)")
    return spec, system, basis, "thin-aerofoil"
