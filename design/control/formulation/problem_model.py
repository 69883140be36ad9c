"""The design problem's bridge and closed-loop flap model (:func:`build_model`), the dense
check of a compensator on a layout (:func:`verify_layout`) and the coefficients of a warm
start (:func:`warm_start_theta`): below the multistart driver, so that its steps (starts,
checks, flap count, pair failure, acceptance, the critical-speed search) use them without
importing :mod:`bridgeflap.design.control.search.driver` back; the driver re-exports them."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from bridgeflap.design.control.formulation.nlp import DesignProblem
from bridgeflap.design.control.results.records import Verification
from bridgeflap.design.control.settings import DesignSettings
from bridgeflap.model.aeroelastic.control import Compensator

#: Test hook: when set, every design model is built on the bridge with its stiffnesses and
#: torsional inertia scaled by ``1 +- value`` (e.g. ``1e-12``: last-bit differences in every
#: model matrix), so that a test can show that a design's outcome does not depend on the last
#: bits (``tests/test_design/control/test_reproducible.py``, ``python -m bench.reproducible``).
PERTURB_ENV = "BRIDGEFLAP_PERTURB_REL"
#: With :data:`PERTURB_ENV`: an integer draw; each perturbed input is then scaled by ``1 + value
#: u`` with ``u`` uniform in [-1, 1] from this seed (other signs and sizes per draw), instead
#: of the fixed signs.
PERTURB_SEED_ENV = "BRIDGEFLAP_PERTURB_SEED"
_PERTURBED = ("deck.gj_nm2", "deck.ei_vertical_nm2", "deck.mass_inertia_kgm2_per_m",
              "deck.mass_kg_per_m")


def perturbed(spec):
    """``spec`` as :data:`PERTURB_ENV` (and :data:`PERTURB_SEED_ENV`) ask (unchanged when it
    is unset or 0)."""
    import os

    rel = float(os.environ.get(PERTURB_ENV, "0") or 0.0)
    if rel == 0.0:
        return spec
    d = spec.deck
    seed = os.environ.get(PERTURB_SEED_ENV, "")
    if not seed:
        return spec.replace(**{
            "deck.gj_nm2": d.gj_nm2 * (1.0 + rel),
            "deck.ei_vertical_nm2": d.ei_vertical_nm2 * (1.0 - rel),
            "deck.mass_inertia_kgm2_per_m": d.mass_inertia_kgm2_per_m * (1.0 + rel)})
    u = np.random.default_rng(int(seed)).uniform(-1.0, 1.0, len(_PERTURBED))
    return spec.replace(**{k: getattr(d, k.split(".")[1]) * (1.0 + rel * float(v))
                           for k, v in zip(_PERTURBED, u, strict=True)})


#: Nominal first start (b2, b1, b0, a2, a1): static gain -1 (flap against pitch), mild rate.
NOMINAL_START = np.array([0.0, 0.5, -1.0, 0.05, 0.5])


def build_model(settings: DesignSettings, count=None, modal=None, n_modes=None,
                positions=None, spec=None):
    """Bridge and closed-loop flap model of a design problem.

    Parameters
    ----------
    settings : DesignSettings
    count : int, optional
        Evenly spaced flap count (default ``settings.flap_count``).
    modal : bridgeflap.model.structure.modes.ModalModel, optional
        Reused modal model.
    n_modes : int, optional
        Retained modes (default ``settings.n_modes``).
    positions : array_like, optional
        Flap centres from the main-span mid-point [m] (overrides ``count``).
    spec : bridgeflap.model.structure.spec.BridgeSpec, optional
        The bridge (default: the built-in ``settings.bridge``).

    Returns
    -------
    spec : bridgeflap.model.structure.spec.BridgeSpec
    model : bridgeflap.model.aeroelastic.flaps.ClosedLoopModel
    """
    from bridgeflap.model.aeroelastic.flaps import closed_loop_model
    from bridgeflap.model.structure.loader import load_bridge

    spec = perturbed(load_bridge(settings.bridge if spec is None else spec))
    pos = settings.positions(count) if positions is None else np.asarray(positions, float)
    return spec, closed_loop_model(spec, pos, settings.flap_width_m,
                                   settings.n_modes if n_modes is None else int(n_modes),
                                   settings.flap_chord_m, settings.leading_edge,
                                   settings.trailing_edge, modal=modal)


def verify_layout(settings: DesignSettings, theta, positions, n_modes=None,
                  spec=None, refined=False) -> Verification:
    """Dense check of ``theta`` on the layout ``positions`` [m] with ``n_modes`` (default: the
    verification model, ``settings.verification_modes``), as ``bridgeflap flutter`` sees it;
    ``spec`` the bridge (default ``settings.bridge``); ``refined``: on the refined subset of
    the check grid (:func:`bridgeflap.design.control.formulation.plant.damping_check_refined`: the
    same decisions)."""
    nm = settings.verification_modes if n_modes is None else int(n_modes)
    _, model = build_model(settings, n_modes=nm, positions=positions, spec=spec)
    return DesignProblem(replace(settings, optimise_placement=False), model,
                         numeric=True).verify(theta, refined=refined)


def warm_start_theta(warm_start) -> np.ndarray:
    """Coefficients (b2, b1, b0, a2, a1) of a warm start: a
    :class:`bridgeflap.model.aeroelastic.control.Controller`,
    a :class:`bridgeflap.model.aeroelastic.control.Compensator` or five numbers."""
    k = getattr(warm_start, "compensator", warm_start)
    if isinstance(k, Compensator):
        return np.array([k.b2, k.b1, k.b0, k.a2, k.a1], float)
    th = np.asarray(warm_start, float).ravel()
    if th.size != 5 or not np.all(np.isfinite(th)):
        from bridgeflap.model.errors import BridgeflapInputError

        raise BridgeflapInputError("warm_start", "needs a Controller, a Compensator or five "
                                                 "finite coefficients (b2, b1, b0, a2, a1)")
    return th
