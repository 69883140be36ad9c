"""Erection with flaps (beyond the paper): the closed-loop critical speed of
each erection stage with the flaps that sit on the erected deck.

A stage (:meth:`bridgeflap.model.structure.spec.BridgeSpec.erected`) carries the main-span deck from
mid-span outwards over ``fraction`` of the span. A flap strip of the controller is fitted when the
whole strip lies on that deck (``|x| + w/2 <= fraction L/2``, ``L`` the main span); the others are
not yet hung. With no strip on the deck the stage runs open loop (reported as such). The compensator
is the controller file's, unchanged: a controller designed for the completed bridge, judged on
the stages it was not designed on (do no harm), with the same flutter/divergence
statuses as :func:`bridgeflap.model.analysis.flutter`.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from bridgeflap.model.aeroelastic.control import Controller
from bridgeflap.model.results import ResultData
from bridgeflap.model.structure.spec import BridgeSpec

__all__ = ["STAGE_DESIGN", "ErectionControlResult", "design_for_stage", "erection_closed_loop",
           "flaps_on_deck", "stage_flap_count"]

#: Card overrides of a design for one erection stage (:func:`design_for_stage`): the largest
#: closed-loop critical speed subject to the card's robust margin (``objective =
#: "critical_speed"``, :mod:`design.control.search.critical_speed`), the search from 40 m/s in 5 m/s
#: steps (a stage's open-loop critical speed lies at 32-52 m/s, the paper's Fig. 3 right and
#: ``bridgeflap erection``) to 1 m/s, on a fixed layout of touching strips on the erected
#: deck (a handful of candidates: no placement), one start.
STAGE_DESIGN = {"objective": "critical_speed", "speed_max_m_s": 40.0,
                "critical_speed_step_m_s": 5.0, "critical_speed_tol_m_s": 1.0,
                "optimise_placement": False, "starts": 1}

_KEYS = ("flutter_speed_m_s", "flutter_status", "divergence_speed_m_s", "divergence_status",
         "critical_speed_m_s", "critical_mechanism")


def flaps_on_deck(controller: Controller, spec: BridgeSpec, fraction: float) -> tuple:
    """Strip centres [m] of ``controller`` that lie wholly on a deck erected over ``fraction``
    [-] of ``spec``'s main span, symmetric about mid-span."""
    half = 0.5 * float(fraction) * spec.main_span.length_m
    w = controller.flap_width_m
    return tuple(x for x in controller.flap_strip_positions_m
                 if abs(x) + 0.5 * w <= half + 1e-9)


def _stage(spec, controller, speeds, n_modes, fraction):
    from bridgeflap.model.analysis import closed_loop_flutter, flutter

    kept = flaps_on_deck(controller, spec, fraction)
    row = {"erected_fraction": float(fraction), "flap_strips_on_deck": len(kept)}
    if kept:
        res = closed_loop_flutter(spec, replace(controller, flap_strip_positions_m=kept),
                                  speeds, n_modes)
        cl, ol = res.base.summary(), res.open_loop.summary()
    else:
        ol = flutter(spec, speeds, n_modes).summary()
        cl = dict(ol)
    for k in _KEYS:
        row[f"open_loop_{k}"] = ol.get(k)
        row[f"closed_loop_{k}"] = cl.get(k)
    row["loop"] = "closed" if kept else "open (no flap on the erected deck)"
    # no crossing of either kind on the grid: stable to its end (no critical speed to report)
    row["closed_loop_stable_over_grid_to_m_s"] = (
        float(speeds[-1]) if cl.get("flutter_status") == cl.get("divergence_status")
        == "no_crossing_in_range" else None)
    o, c = ol.get("critical_speed_m_s"), cl.get("critical_speed_m_s")
    ok = all(isinstance(v, float) and np.isfinite(v) for v in (o, c))
    row["closed_over_open"] = c / o if ok else float("nan")
    return row


@dataclass(frozen=True)
class ErectionControlResult(ResultData):
    """Open- and closed-loop critical speeds per erection stage; ``rows`` one dict per stage
    (the completed bridge last), ``status`` ``ok`` or what did not converge."""

    bridge: str
    rows: tuple
    side_spans: str

    @property
    def status(self) -> str:
        """``ok`` when every stage's closed-loop critical speed converged."""
        ok = ("converged", "no_crossing_in_range")
        bad = [r for r in self.rows
               if r["closed_loop_flutter_status"] not in ok
               or r["closed_loop_divergence_status"] not in ok]
        return "ok" if not bad else f"{len(bad)} of {len(self.rows)} stages with an " \
                                    "unconverged closed-loop crossing"

    def summary(self) -> dict:
        """JSON-ready: the stages and the worst one (lowest closed-loop critical speed)."""
        speeds = [r["closed_loop_critical_speed_m_s"] for r in self.rows]
        finite = [i for i, v in enumerate(speeds) if isinstance(v, float) and np.isfinite(v)]
        worst = min(finite, key=lambda i: speeds[i]) if finite else None
        return {"bridge": self.bridge, "side_spans": self.side_spans, "status": self.status,
                "stages": list(self.rows),
                "worst_stage_erected_fraction": (self.rows[worst]["erected_fraction"]
                                                 if worst is not None else None),
                "worst_closed_loop_critical_speed_m_s": (speeds[worst] if worst is not None
                                                         else None)}

    def to_dataframe(self):
        """One row per stage (pandas)."""
        import pandas as pd

        return pd.DataFrame(list(self.rows))

    _HEADLINE_KEYS = ("bridge", "side_spans", "worst_stage_erected_fraction",
                      "worst_closed_loop_critical_speed_m_s", "status")

    def _headline(self) -> dict:
        return {**super()._headline(), "stages": len(self.rows)}

    def plot(self, ax=None):
        """Open- and closed-loop critical speeds against the erected fraction
        (:func:`bridgeflap.design.control.results.result_plots.erection_stages`)."""
        from bridgeflap.design.control.results.result_plots import erection_stages

        return erection_stages(self, ax)


def erection_closed_loop(spec: BridgeSpec, controller: Controller, fractions, speeds,
                         n_modes: int, side_spans: str | None = None,
                         progress=None) -> ErectionControlResult:
    """Open- and closed-loop flutter/divergence at each erected fraction [-] and for the
    completed bridge, with the controller's flaps that sit on the erected deck.

    ``progress``: a callable given one line once every input is checked (the stages and
    the strips), before the stages run (default: none)."""
    from bridgeflap.model.analysis import _fractions, check_speeds

    fr = _fractions(fractions)
    speeds = check_speeds(speeds)
    check_stage_modes(spec, fr, n_modes, side_spans)  # every stage before the first runs
    if progress is not None:
        progress(f"erection with flaps: {len(fr)} stages + the completed bridge, "
                 f"{len(controller.flap_strip_positions_m)} flap strips in the file")
    rows = []
    for f in fr:
        row = _stage(spec.erected(float(f), side_spans=side_spans), controller, speeds,
                     n_modes, float(f))
        row["stage"] = "closed deck, temporary joints" if f >= 1.0 else "erecting"
        rows.append(row)
    done = _stage(spec.completed(), controller, speeds, n_modes, 1.0)
    done["stage"] = "completed bridge"
    rows.append(done)
    side = spec.erected(1.0, side_spans=side_spans).side_span_decks
    return ErectionControlResult(spec.name, tuple(rows), side)


def check_stage_modes(spec: BridgeSpec, fractions, n_modes: int,
                      side_spans: str | None = None, field: str = "modes") -> None:
    """Raise naming ``field`` when a stage at ``fractions`` [-] or the completed bridge has
    fewer vertical and torsional modes than ``n_modes``.

    Parameters
    ----------
    spec : BridgeSpec
        The completed bridge.
    fractions : array_like
        Erected fractions of the main span [-], each in (0, 1].
    n_modes : int
        Retained vertical + torsional modes of every stage.
    side_spans : str, optional
        Side-span decks while erecting (default: the bridge file's).
    field : str, default "modes"
        The name a refusal gives (``"modes"``: the command line's ``--modes``).

    Raises
    ------
    BridgeflapInputError
        Naming ``field``: a stage's model has too few modes. Checked before any stage runs
        (each stage's modal model, a fraction of a second), so that a refusal follows no
        progress line.
    """
    from bridgeflap.design.io.api_args import check_model_modes
    from bridgeflap.model.analysis import _fractions

    for f in _fractions(fractions):
        check_model_modes(spec.erected(float(f), side_spans=side_spans), n_modes, field)
    check_model_modes(spec.completed(), n_modes, field)


def stage_design_count(spec: BridgeSpec, fraction: float, card=None) -> int:
    """The flap strips of ``card`` (default: the packaged card) that fit on the deck erected
    over ``fraction`` [-]: what :func:`design_for_stage` lays out.

    Raises
    ------
    BridgeflapInputError
        ``fraction``: not one strip fits (checked before the design runs).
    """
    from bridgeflap.design.control.settings import DEFAULT_CARD, load_settings
    from bridgeflap.model.errors import BridgeflapInputError

    base = load_settings(DEFAULT_CARD if card is None else card)
    n = stage_flap_count(spec, fraction, base.flap_width_m)
    if n < 1:
        raise BridgeflapInputError("fraction", f"{fraction:g}: no {base.flap_width_m:g} m flap "
                                   "strip fits on the erected deck")
    return n


def stage_flap_count(spec: BridgeSpec, fraction: float, flap_width_m: float) -> int:
    """Touching strips of ``flap_width_m`` [m] that fit on a main-span deck erected over
    ``fraction`` [-] from mid-span (the evenly spaced layout of the card's width)."""
    return int(np.floor(float(fraction) * spec.main_span.length_m / float(flap_width_m)
                        + 1e-9))


def design_for_stage(spec: BridgeSpec, fraction: float, card=None, progress=None,
                     side_spans: str | None = None, **overrides):
    """A controller designed for one erection stage: the card's flaps and
    limits (gain, chord, damping, margin_min), the strips that fit on the erected deck as the
    layout, and :data:`STAGE_DESIGN` (maximise the closed-loop critical speed); ``overrides``
    are further card keys. Returns the
    :class:`bridgeflap.design.control.results.result.DesignResult` (its status as the design reports
    it: ``converged`` only when the critical-speed search is bracketed and the chosen design
    verifies)."""
    from bridgeflap.design.control.search.driver import design
    from bridgeflap.design.control.settings import DEFAULT_CARD, load_settings

    card = DEFAULT_CARD if card is None else card
    n = stage_design_count(spec, fraction, card)
    settings = load_settings(card, **({"flap_count": n, "flap_positions_m": ()} | STAGE_DESIGN
                                      | overrides))
    stage = spec.erected(float(fraction), side_spans=side_spans)
    return design(settings, progress=progress, bridge=stage, progress_bar=False)
