"""bridgeflap.model: physics of a suspension bridge with active deck flaps.

Rooms, bottom to top (each imports only itself and the rooms below it;
tests/project/test_layering.py holds the rule): the foundation (the top-level modules
``errors``, ``lazy``, ``results``, ``vocabulary``, ``grid``, ``workers``, ``progress``,
``spectrum``, ``spectral``, ``axes``), :mod:`bridgeflap.model.aero`,
:mod:`bridgeflap.model.structure`, :mod:`bridgeflap.model.aeroelastic`,
:mod:`bridgeflap.model.stability`, :mod:`bridgeflap.model.response`, the facade
:mod:`bridgeflap.model.analysis`, and the reference cases :mod:`bridgeflap.model.cases`. Nothing in
:mod:`bridgeflap.model` imports :mod:`bridgeflap.design`.

Conventions (stated once here and in the README; every module refers back)
---------------------------------------------------------------------------
* SI units everywhere. Any other unit is in the name (``frequency_hz``, ``angle_deg``).
* Deck heave ``h`` is positive **downward**; pitch ``alpha`` is positive **nose-up**
  (leading edge up, wind blowing from the leading edge); the pitching moment is taken about
  **mid-chord** (elastic axis at mid-chord, Theodorsen's ``a = 0``), positive nose-up.
* Lift ``L`` in the structural equations is positive **downward** (the paper's Eq. (2));
  Theodorsen's upward lift is ``-L``.
* ``b`` is the aerodynamic half-chord [m]; reduced frequency ``k = omega * b / U``;
  Laplace variable in aerodynamic time ``s_bar = s * b / U``.
* Theodorsen's apparent-inertia moment term ``-pi rho b^4 alpha_ddot / 8`` (the paper's Eq. (3)) is
  kept by default (``added_inertia=True``); bridge practice (Scanlan flat-plate derivatives) drops
  it.
* The three structural families (vertical, lateral, torsional) are uncoupled; aerodynamics
  couples vertical and torsional only (thin-aerofoil theory gives lift and moment, no drag).
* x is measured along the bridge from the north (Hessle) anchorage [m]; spans are listed
  north to south; "symmetric" refers to the main-span mid-point.
"""

# ------------------------------------------------------------------ public face (lazy)
#: What a script imports: ``from model import load_bridge, flutter, ...``. Names resolve on
#: first use (PEP 562), so ``import model`` stays light (no CasADi, no matplotlib).
_PUBLIC = {
    "BridgeSpec": "bridgeflap.model.structure.spec",
    "load_bridge": "bridgeflap.model.structure.loader",
    "spec_from_dict": "bridgeflap.model.structure.loader",
    "PARAMETER_PATHS": "bridgeflap.model.structure.spec",
    "save_bridge": "bridgeflap.model.structure.spec_writer",
    "BridgeflapError": "bridgeflap.model.errors", "BridgeflapInputError": "bridgeflap.model.errors",
    "DEFAULT_MODES": "bridgeflap.model.analysis", "modal_model": "bridgeflap.model.analysis",
    "bridge_system": "bridgeflap.model.analysis", "flutter": "bridgeflap.model.analysis",
    "erection": "bridgeflap.model.analysis",
    "frequency_ratio": "bridgeflap.model.analysis",
    "closed_loop_flutter": "bridgeflap.model.analysis",
    "pk_flutter": "bridgeflap.model.analysis", "FlutterResult": "bridgeflap.model.analysis",
    "mode_convergence": "bridgeflap.model.stability.convergence",
    "truncation_error": "bridgeflap.model.stability.convergence",
    "flutter_mode_shape": "bridgeflap.model.stability.modeshape",
    "sweep": "bridgeflap.model.stability.sweeps", "pk_sweep": "bridgeflap.model.stability.sweeps",
    "buffeting": "bridgeflap.model.response.buffeting",
    "Compensator": "bridgeflap.model.aeroelastic.control",
    "Controller": "bridgeflap.model.aeroelastic.control",
    "load_controller": "bridgeflap.model.aeroelastic.controller_file",
    "save_controller": "bridgeflap.model.aeroelastic.controller_file",
    "closed_loop_model": "bridgeflap.model.aeroelastic.flaps",
    "closed_loop_state_space": "bridgeflap.model.aeroelastic.flaps",
    "plant": "bridgeflap.model.aeroelastic.control_plant",
    "plant_data": "bridgeflap.model.aeroelastic.control_plant",
    "Plant": "bridgeflap.model.aeroelastic.control_plant",
    "closed_loop": "bridgeflap.model.aeroelastic.control_interop",
    "plant_family": "bridgeflap.model.aeroelastic.control_interop",
    "build_symbolic": "bridgeflap.model.aeroelastic.symbolic",
    "closed_loop_functions": "bridgeflap.model.aeroelastic.symbolic",
    "section_basis": "bridgeflap.model.cases.section",
    "typical_section": "bridgeflap.model.cases.section",
}
#: The flat modules before the rooms and where they went: importing one gives
#: a one-line ModuleNotFoundError naming its new home (model.lazy.moved_modules).
_MOVED = {
    "actuator_limits": "bridgeflap.model.aeroelastic.actuator_limits",
    "actuator_sim": "bridgeflap.model.response.actuator_sim",
    "assembly": "bridgeflap.model.aeroelastic.assembly",
    "backend": "bridgeflap.model.aeroelastic.backend", "basis": "bridgeflap.model.aero.basis",
    "bridge_arg": "bridgeflap.model.structure.bridge_arg",
    "buffeting": "bridgeflap.model.response.buffeting",
    "buffeting_inputs": "bridgeflap.model.response.buffeting_inputs",
    "cable": "bridgeflap.model.structure.cable",
    "control": "bridgeflap.model.aeroelastic.control",
    "control_interop": "bridgeflap.model.aeroelastic.control_interop",
    "control_plant": "bridgeflap.model.aeroelastic.control_plant",
    "controller_file": "bridgeflap.model.aeroelastic.controller_file",
    "convergence": "bridgeflap.model.stability.convergence",
    "derivative_system": "bridgeflap.model.aeroelastic.derivative_system",
    "derivatives": "bridgeflap.model.aero.derivatives", "fe": "bridgeflap.model.structure.fe",
    "flaps": "bridgeflap.model.aeroelastic.flaps", "gust": "bridgeflap.model.aero.gust",
    "hopf": "bridgeflap.model.stability.hopf",
    "hopf_newton": "bridgeflap.model.stability.hopf_newton",
    "limits": "bridgeflap.model.structure.limits",
    "modal_files": "bridgeflap.model.structure.modal_files",
    "modal_import": "bridgeflap.model.structure.modal_import",
    "modal_model": "bridgeflap.model.structure.modal_model",
    "modes": "bridgeflap.model.structure.modes",
    "modeshape": "bridgeflap.model.stability.modeshape", "pk": "bridgeflap.model.stability.pk",
    "pk_kernel": "bridgeflap.model.stability.pk_kernel",
    "plots": "bridgeflap.model.structure.plots, bridgeflap.model.stability.plots, "
    "bridgeflap.model.response.plots",
    "quasi_steady": "bridgeflap.model.aero.quasi_steady", "rfa": "bridgeflap.model.aero.rfa",
    "rfa_cases": "bridgeflap.model.cases.rfa_cases", "ritz": "bridgeflap.model.structure.ritz",
    "section": "bridgeflap.model.cases.section",
    "section_cases": "bridgeflap.model.cases.section_cases",
    "section_props": "bridgeflap.model.structure.section_props",
    "simulation": "bridgeflap.model.response.simulation",
    "spec": "bridgeflap.model.structure.spec (load_bridge, spec_from_dict: "
    "bridgeflap.model.structure.loader)",
    "spec_writer": "bridgeflap.model.structure.spec_writer",
    "statespace": "bridgeflap.model.aeroelastic.statespace",
    "static_divergence": "bridgeflap.model.stability.static_divergence",
    "symbolic": "bridgeflap.model.aeroelastic.symbolic",
    "theodorsen": "bridgeflap.model.aero.theodorsen",
    "tracking": "bridgeflap.model.stability.tracking",
    "turbulence": "bridgeflap.model.aero.turbulence",
    "validation": "bridgeflap.model.cases.validation", "wind": "bridgeflap.model.aero.wind",
}
from bridgeflap.model.lazy import (  # noqa: E402 - after the tables they serve
    keep_public_names,
    moved_modules,
    public_face,
)

__all__, __getattr__, __dir__ = public_face(__name__, _PUBLIC)
keep_public_names(__name__)  # model.<function> is never shadowed by a submodule
moved_modules(__name__, _MOVED)  # import model.<old flat module>: where it went
