"""bridgeflap.model: physics of a suspension bridge with active deck flaps.

Rooms, bottom to top (each imports only itself and the rooms below it;
tests/project/test_layering.py holds the rule): the foundation (the top-level modules
``errors``, ``lazy``, ``results``, ``vocabulary``, ``grid``, ``workers``, ``spectrum``,
``spectral``, ``axes``), :mod:`model.aero`, :mod:`model.structure`, :mod:`model.aeroelastic`,
:mod:`model.stability`, :mod:`model.response`, the facade :mod:`model.analysis`, and the
reference cases :mod:`model.cases`. Nothing in :mod:`model` imports :mod:`design`.

Conventions (stated once here and in the README; every module refers back)
---------------------------------------------------------------------------
* SI units everywhere. Any other unit is in the name (``frequency_hz``, ``angle_deg``).
* Deck heave ``h`` is positive **downward**; pitch ``alpha`` is positive **nose-up**
  (leading edge up, wind blowing from the leading edge); the pitching moment is taken about
  **mid-chord** (elastic axis at mid-chord, Theodorsen's ``a = 0``), positive nose-up.
* Lift ``L`` in the structural equations is positive **downward** (the seed paper's Eq. (2));
  Theodorsen's upward lift is ``-L``.
* ``b`` is the aerodynamic half-chord [m]; reduced frequency ``k = omega * b / U``;
  Laplace variable in aerodynamic time ``s_bar = s * b / U``.
* Theodorsen's apparent-inertia moment term ``-pi rho b^4 alpha_ddot / 8`` (seed Eq. (3)) is kept
  by default (``added_inertia=True``); bridge practice (Scanlan flat-plate derivatives) drops it.
* The three structural families (vertical, lateral, torsional) are uncoupled; aerodynamics
  couples vertical and torsional only (thin-aerofoil theory gives lift and moment, no drag).
* x is measured along the bridge from the north (Hessle) anchorage [m]; spans are listed
  north to south; "symmetric" refers to the main-span mid-point.
"""

# ------------------------------------------------------------------ public face (lazy)
#: What a script imports: ``from model import load_bridge, flutter, ...``. Names resolve on
#: first use (PEP 562), so ``import model`` stays light (no CasADi, no matplotlib).
_PUBLIC = {
    "BridgeSpec": "model.structure.spec", "load_bridge": "model.structure.loader",
    "spec_from_dict": "model.structure.loader", "PARAMETER_PATHS": "model.structure.spec",
    "save_bridge": "model.structure.spec_writer",
    "BridgeflapError": "model.errors", "BridgeflapInputError": "model.errors",
    "DEFAULT_MODES": "model.analysis", "modal_model": "model.analysis",
    "bridge_system": "model.analysis", "flutter": "model.analysis", "erection": "model.analysis",
    "frequency_ratio": "model.analysis", "closed_loop_flutter": "model.analysis",
    "pk_flutter": "model.analysis", "FlutterResult": "model.analysis",
    "mode_convergence": "model.stability.convergence",
    "truncation_error": "model.stability.convergence",
    "flutter_mode_shape": "model.stability.modeshape",
    "sweep": "model.stability.sweeps", "pk_sweep": "model.stability.sweeps",
    "buffeting": "model.response.buffeting",
    "Compensator": "model.aeroelastic.control", "Controller": "model.aeroelastic.control",
    "load_controller": "model.aeroelastic.controller_file",
    "save_controller": "model.aeroelastic.controller_file",
    "closed_loop_model": "model.aeroelastic.flaps",
    "closed_loop_state_space": "model.aeroelastic.flaps",
    "plant": "model.aeroelastic.control_plant", "plant_data": "model.aeroelastic.control_plant",
    "Plant": "model.aeroelastic.control_plant",
    "closed_loop": "model.aeroelastic.control_interop",
    "plant_family": "model.aeroelastic.control_interop",
    "build_symbolic": "model.aeroelastic.symbolic",
    "closed_loop_functions": "model.aeroelastic.symbolic",
    "section_basis": "model.cases.section", "typical_section": "model.cases.section",
}
#: The flat modules before the rooms and where they went: importing one gives
#: a one-line ModuleNotFoundError naming its new home (model.lazy.moved_modules).
_MOVED = {
    "actuator_limits": "model.aeroelastic.actuator_limits",
    "actuator_sim": "model.response.actuator_sim", "assembly": "model.aeroelastic.assembly",
    "backend": "model.aeroelastic.backend", "basis": "model.aero.basis",
    "bridge_arg": "model.structure.bridge_arg", "buffeting": "model.response.buffeting",
    "buffeting_inputs": "model.response.buffeting_inputs", "cable": "model.structure.cable",
    "control": "model.aeroelastic.control", "control_interop": "model.aeroelastic.control_interop",
    "control_plant": "model.aeroelastic.control_plant",
    "controller_file": "model.aeroelastic.controller_file",
    "convergence": "model.stability.convergence",
    "derivative_system": "model.aeroelastic.derivative_system",
    "derivatives": "model.aero.derivatives", "fe": "model.structure.fe",
    "flaps": "model.aeroelastic.flaps", "gust": "model.aero.gust", "hopf": "model.stability.hopf",
    "hopf_newton": "model.stability.hopf_newton", "limits": "model.structure.limits",
    "modal_files": "model.structure.modal_files", "modal_import": "model.structure.modal_import",
    "modal_model": "model.structure.modal_model", "modes": "model.structure.modes",
    "modeshape": "model.stability.modeshape", "pk": "model.stability.pk",
    "pk_kernel": "model.stability.pk_kernel",
    "plots": "model.structure.plots, model.stability.plots, model.response.plots",
    "quasi_steady": "model.aero.quasi_steady", "rfa": "model.aero.rfa",
    "rfa_cases": "model.cases.rfa_cases", "ritz": "model.structure.ritz",
    "section": "model.cases.section", "section_cases": "model.cases.section_cases",
    "section_props": "model.structure.section_props", "simulation": "model.response.simulation",
    "spec": "model.structure.spec (load_bridge, spec_from_dict: model.structure.loader)",
    "spec_writer": "model.structure.spec_writer",
    "statespace": "model.aeroelastic.statespace",
    "static_divergence": "model.stability.static_divergence",
    "symbolic": "model.aeroelastic.symbolic", "theodorsen": "model.aero.theodorsen",
    "tracking": "model.stability.tracking", "turbulence": "model.aero.turbulence",
    "validation": "model.cases.validation", "wind": "model.aero.wind",
}
from model.lazy import (  # noqa: E402 - after the tables they serve
    keep_public_names,
    moved_modules,
    public_face,
)

__all__, __getattr__, __dir__ = public_face("model", _PUBLIC)
keep_public_names(__name__)  # model.<function> is never shadowed by a submodule
moved_modules(__name__, _MOVED)  # import model.<old flat module>: where it went
