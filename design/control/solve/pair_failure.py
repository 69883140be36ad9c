"""Design for one-pair failure: each one-pair-failed plant as an extra model.

``design_for_pair_failure = true`` on a design card adds, for every flap pair ``f`` of the
fixed layout whose K(s) is optimised (the card's layout, or the rounded one of a placement),
the same bridge with pair ``f`` stuck at 0 as one more model of the multi-model design
(:mod:`bridgeflap.design.control.formulation.variants`): its damping constraints at the design
speeds (lazily generated like a bridge variant's) and its dense check, so the design verifies only
when every one-pair-failed loop meets ``zeta_min`` on ``0 .. speed_max`` as well. A failed pair is
weight 0 on its flap loads (:class:`FailedPairProblem`, the weights of the placement;
:mod:`bridgeflap.design.assessment.failsafe` judges a controller the same way). The relaxed
placement solve is not given them: which pair fails is a question of the layout it chooses.
"""

from __future__ import annotations

import numpy as np

from bridgeflap.design.control.formulation.nlp import DesignProblem

__all__ = ["FailedPairProblem", "extra_models", "pair_label"]


class FailedPairProblem(DesignProblem):
    """A :class:`~bridgeflap.design.control.formulation.nlp.DesignProblem` on ``model`` with flap
    pair ``pair`` failed: its weight is 0 whatever weights the caller passes (a multi-model check
    passes the nominal problem's)."""

    def __init__(self, settings, model, pair: int, spec=None):
        self.mask = np.ones(model.n_flaps)
        self.mask[int(pair)] = 0.0
        super().__init__(settings, model, weights=self.mask.copy(), spec=spec)
        self.pair = int(pair)

    def A_parts(self, theta, weights=None) -> tuple:
        """The closed loop's parts with this pair's weight 0."""
        w = self.weights if weights is None else np.asarray(weights, float) * self.mask
        return super().A_parts(theta, w)


def extra_models(settings, model, spec, variants, positions=None) -> list:
    """The extra models of a fixed-layout design: one
    :class:`~bridgeflap.design.control.formulation.nlp.DesignProblem` per bridge variant
    (``variants``: specs; the layout ``positions``, default the card's), then, with
    ``design_for_pair_failure``, one :class:`FailedPairProblem` per flap pair of ``model`` (the
    nominal bridge)."""
    from bridgeflap.design.control.formulation.problem_model import build_model
    from bridgeflap.design.control.solve.scenarios import scenario_settings

    out = []
    for v in variants:
        m = build_model(settings, positions=positions, spec=v)[1]
        sv = scenario_settings(settings, v, m)   # no_harm: held below its own critical speed
        if sv is not None:
            out.append(DesignProblem(sv, m, spec=v))
            if sv.actuator_design_speeds_m_s:
                out[-1].demand_held = False     # checked each round (variants.demand_checks)
    if getattr(settings, "design_for_pair_failure", False):
        out += [FailedPairProblem(settings, model, f, spec=spec) for f in range(model.n_flaps)]
    return out


def pair_label(problem) -> dict:
    """``{"failed_pair", "failed_pair_position_m"}`` of a :class:`FailedPairProblem` (the
    label of its entry in a start's ``variant_checks``), ``{}`` for a bridge variant."""
    if not isinstance(problem, FailedPairProblem):
        return {}
    return {"failed_pair": problem.pair,
            "failed_pair_position_m": float(problem.model.flaps.position_m[problem.pair])}
