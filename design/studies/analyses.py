"""The one registry of analyses: name -> runner, defaults, options, DOE case row.

The command line (:mod:`bridgeflap.design.cli.main`), studies
(:mod:`bridgeflap.design.studies.study`) and DOE cases (:mod:`bridgeflap.design.studies.cases`) all
take an analysis' defaults from :data:`ANALYSES`, so a default lives in one place: the wind-speed
grid of flutter and erection is :data:`DEFAULT_SPEEDS`, the number of retained modes
:data:`DEFAULT_MODES` (the same object as
:data:`bridgeflap.model.analysis.DEFAULT_MODES`).

Each :class:`Analysis` runs on a bridge definition with its resolved options
(:meth:`Analysis.resolve`: defaults, then the given options) and returns an :class:`Outcome`:
an overall status, the JSON-ready summary, arrays to store, figures and the result object.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any

import numpy as np

from bridgeflap.design.io.options import (
    MAX_MODES,
    check_bool,
    check_choice,
    check_int,
    check_number,
    check_option_names,
    grid,
    parse_range,
)
from bridgeflap.design.sensitivity.local import DEFAULT_PARAMETERS
from bridgeflap.model.analysis import DEFAULT_MODES
from bridgeflap.model.errors import BridgeflapInputError
from bridgeflap.model.progress import counted
from bridgeflap.model.structure.builtin_bridges import BUILTIN_BRIDGES
from bridgeflap.model.structure.spec import BridgeSpec

__all__ = ["ANALYSES", "DEFAULT_MODES", "DEFAULT_SPEEDS", "Analysis", "Outcome", "RunContext",
           "check_options", "figure_of"]

#: default wind-speed grid [m/s] of flutter and erection (the paper's Fig. 3: 0-85 m/s)
DEFAULT_SPEEDS = "0:85:0.5"


@dataclass(frozen=True)
class RunContext:
    """How an analysis is run: the bridge it came from, quick mode, figures, progress, and
    how many worker processes it may use for independent parts (erection stages)."""

    bridge: Any = "humber"  # a built-in name, a bridge TOML path or a BridgeSpec
    quick: bool = False
    figures: bool = True
    progress: Callable[[str], None] | None = None
    workers: int = 1

    def say(self, msg: str) -> None:
        """Report one line of progress (if anyone listens)."""
        if self.progress is not None:
            self.progress(msg)


@dataclass(frozen=True)
class Outcome:
    """What one analysis produced.

    Attributes
    ----------
    status : str
        ``"ok"``, or why not (``"failed: ..."``, ``"2 of 7 stages: flutter ..."``).
    summary : Mapping
        JSON-ready numbers (units in the key names) and solver statuses.
    arrays : Mapping
        Named arrays to store (``results/<analysis>.npz``).
    figures : Mapping
        Figure name -> matplotlib figure (empty when figures are off).
    result : Any
        The analysis' own result object.
    """

    status: str
    summary: Mapping = field(default_factory=dict)
    arrays: Mapping = field(default_factory=dict)
    figures: Mapping = field(default_factory=dict)
    result: Any = None


@dataclass(frozen=True)
class Analysis:
    """One registered analysis.

    Attributes
    ----------
    name : str
        Registry key (study and DOE files use it).
    run : callable
        ``run(spec, options, context) -> Outcome`` with resolved ``options``.
    defaults : Mapping
        Option name -> default value (grids as text, ``start:stop:step``).
    options : tuple of str or None
        Accepted option names; ``None`` passes any option through to the analysis.
    case : callable or None
        ``case(outcome) -> dict``, the row of a DOE case; ``None`` if not a DOE analysis.
    """

    name: str
    run: Callable[[BridgeSpec, dict, RunContext], Outcome]
    defaults: Mapping
    options: tuple | None
    case: Callable[[Outcome], dict] | None = None

    def resolve(self, options: Mapping | None = None, what: str | None = None) -> dict:
        """The defaults updated with ``options`` (names and values checked)."""
        options = dict(options or {})
        check_option_names(self.name, options, self.options, what or self.name)
        check_options(self.name, options, what or self.name)
        return {**self.defaults, **options}

    def __call__(self, spec: BridgeSpec, options: Mapping | None = None,
                 context: RunContext | None = None) -> Outcome:
        """Run on ``spec`` with the defaults updated by ``options``."""
        return self.run(spec, self.resolve(options), context or RunContext())


def _speeds(value, field_name):
    grid(value, field_name, 0.0)


def _fractions(value, field_name):
    from bridgeflap.model.structure.spec import check_fraction

    for f in grid(value, field_name, None, None):
        try:
            check_fraction(f)
        except BridgeflapInputError as exc:
            raise BridgeflapInputError(field_name, exc.reason) from None


def _modes(value, field_name):
    check_int(value, field_name, 1, MAX_MODES)


def _side_spans(value, field_name):
    from bridgeflap.model.structure.spec import SIDE_SPAN_SEQUENCES

    check_choice(value, field_name, ("", *SIDE_SPAN_SEQUENCES))


def _choice(*choices):
    return lambda value, field_name: check_choice(value, field_name, choices)


def _number(minimum=None, maximum=None, strict=False):
    return lambda value, field_name: check_number(value, field_name, minimum, maximum, strict)


def _integer(minimum=1, maximum=None):
    return lambda value, field_name: check_int(value, field_name, minimum, maximum)


def _parameters(value, field_name):
    # design/sensitivity/local.py (H1): one import line
    from bridgeflap.design.sensitivity.local import check_parameters

    if not (isinstance(value, str) or (isinstance(value, list | tuple)
                                       and all(isinstance(v, str) for v in value))):
        raise BridgeflapInputError(field_name, f"must be a comma list or a list of parameter "
                                               f"paths, got {value!r}")
    try:
        check_parameters(value)
    except BridgeflapInputError as exc:
        raise BridgeflapInputError(field_name, exc.reason) from None


def _option_checks() -> dict:
    """Option name -> ``check(value, field)``: every option a study, DOE or CLI may set."""
    from bridgeflap.model.aero.rfa import RFA_NAMES
    from bridgeflap.model.aero.wind import ADMITTANCE_KINDS, SPECTRUM_KINDS
    from bridgeflap.model.response.buffeting import METHODS

    positive = _number(0.0, strict=True)
    return {
        "speeds": _speeds, "fractions": _fractions, "modes": _modes,
        "count": _integer(1, 100000), "rfa": _choice(*RFA_NAMES),
        "order": _choice("modal", "full"), "side_spans": _side_spans,
        "sweep": _choice("dense", "fast"),
        "parameters": _parameters, "check": check_bool, "truncation_check": check_bool,
        # model.response.buffeting.buffeting
        "spectrum": _choice(*SPECTRUM_KINDS), "admittance": _choice(*ADMITTANCE_KINDS),
        "coherence_decay": _number(0.0), "method": _choice(*METHODS),
        "turbulence_intensity": _number(0.0, 1.0, strict=True), "deck_height_m": positive,
        "length_scale_m": positive, "half_chord_m": positive, "allow_unstable": check_bool,
        "omega_max": positive, "n_base": _integer(2, 100000),
        "peaks_per_mode": _integer(1, 10000), "half_widths": positive,
        "convergence_tol": positive, "mc_records": _integer(2, 10000),
        "mc_seed": _integer(0, 2 ** 32 - 1), "mc_points": _integer(2, 1000000),
    }


def check_options(kind: str, opts: Mapping, what: str | None = None) -> None:
    """Validate option values now, so that bad input exits before anything is written.

    Every option named in :func:`_option_checks` is checked for its type and range; the
    ``design`` analysis' options are :class:`bridgeflap.design.control.settings.DesignSettings`
    fields, checked by building the settings. Unknown names are rejected by
    :meth:`Analysis.resolve`.
    """
    what = what or kind
    if kind == "design":
        try:
            design_settings(opts, bridge=None)
        except BridgeflapInputError as exc:
            raise BridgeflapInputError(f"{what}.{exc.field}", exc.reason) from None
        return
    checks = _option_checks()
    for key, value in opts.items():
        check = checks.get(key)
        if check is not None:
            check(value, f"{what}.{key}")


def figure_of(drawn):
    """The figure of a plot: a figure, an axis or the first of several axes."""
    from bridgeflap.model.results import figure_of as _figure_of

    return _figure_of(drawn)


def _figures(context: RunContext, name: str, result) -> dict:
    return {name: figure_of(result.plot())} if context.figures else {}


def aggregate_status(status) -> str:
    """One status from a per-point list: ``ok`` or ``k of n points: <statuses>``."""
    if isinstance(status, list | tuple):
        bad = [str(x) for x in status if x not in ("ok", "converged")]
        return "ok" if not bad else f"{len(bad)} of {len(status)} points: " + ", ".join(
            sorted(set(bad)))
    return str(status)


# ------------------------------------------------------------------------------ runners


def _run_modes(spec, opts, context) -> Outcome:
    from bridgeflap.model.analysis import modal_model
    from bridgeflap.model.cases.validation import compare_table1

    modal = modal_model(spec)
    s = {"cable_horizontal_tension_n": modal.structure.statics.horizontal_tension_n,
         "cable_main_sag_m": modal.structure.statics.main_sag_m,
         "modes": modal.mode_records()[: int(opts["count"])], "table1": compare_table1(modal)}
    freq = np.array([m["frequency_hz"] for m in s["modes"]])
    # mode shapes along the deck (model.structure.modes.ModalModel.deck_shapes), the listed modes
    # only
    shapes = modal.deck_shapes()
    n = freq.size
    arr = {"frequency_hz": freq, "labels": shapes["labels"][:n], "family": shapes["family"][:n],
           "node_x_m": shapes["node_x_m"], "node_span": shapes["node_span"],
           "shape": shapes["shape"][:n]}
    return Outcome("ok", s, arr, _figures(context, "modes", modal), modal)


def _modes_case(outcome: Outcome) -> dict:
    from bridgeflap.model.analysis import first_symmetric_frequency_hz

    modal = outcome.result
    fv = first_symmetric_frequency_hz(modal, "vertical")
    ft = first_symmetric_frequency_hz(modal, "torsional")
    return {"vs1_hz": fv, "ts1_hz": ft, "frequency_ratio": ft / fv,
            "cable_horizontal_tension_n": modal.structure.statics.horizontal_tension_n}


def _run_frequency_ratio(spec, opts, context) -> Outcome:
    from bridgeflap.model.analysis import frequency_ratio

    res = frequency_ratio(spec, grid(opts["fractions"], "fractions"),
                          side_spans=opts["side_spans"] or None)
    bad = [st for st in res.stages if not np.isfinite(st["ratio_half_gj"])]
    status = "ok" if not bad else f"partial: {len(bad)} stages without a symmetric pair"
    arr = {k: np.array([st[k] for st in res.stages], dtype=float)
           for k in ("erected_fraction", "ratio_full_gj", "ratio_half_gj")}
    figs = _figures(context, "frequency_ratio", res)
    if context.figures:  # the modes the rule picks (model.analysis.first_symmetric_deck_mode)
        from bridgeflap.model.analysis import first_symmetric_deck_mode
        from bridgeflap.model.stability.modeshape import plot_ratio_modes, ratio_modes

        picked = ratio_modes(spec, first_symmetric_deck_mode, (0.2, 0.5, 0.8, 1.0),
                             side_spans=opts["side_spans"] or None)
        figs["frequency_ratio_modes"] = figure_of(plot_ratio_modes(picked))
    return Outcome(status, res.summary(), arr, figs, res)


def _run_flutter(spec, opts, context) -> Outcome:
    from bridgeflap.model.analysis import flutter

    # a run that draws the V-g/V-f figures needs eigenvalues at every grid speed: dense sweep
    method = "dense" if context.figures else opts["sweep"]
    res = flutter(spec, grid(opts["speeds"], "speeds", 0.0), n_modes=int(opts["modes"]),
                  order=opts["order"], rfa=opts["rfa"], sweep_method=method)
    s = res.summary()
    if opts["truncation_check"] and opts["order"] == "modal":
        s = {**s, **_truncation(spec, opts, res)}
    status = ("ok" if s["flutter_status"] == "converged" and s["divergence_status"] == "converged"
              else f"flutter {s['flutter_status']}, divergence {s['divergence_status']}")
    sw = res.sweep
    arr = {"speeds_m_s": sw.speeds, "eigenvalues": sw.eigenvalues, "branches": sw.branches,
           "branch_labels": np.array(sw.branch_labels)}
    figs = _figures(context, "flutter", res)
    if context.figures and s["flutter_status"] == "converged" and opts["order"] == "modal":
        from bridgeflap.model.stability.modeshape import flutter_mode_shape

        shape = flutter_mode_shape(spec, grid(opts["speeds"], "speeds", 0.0), int(opts["modes"]),
                                   rfa=opts["rfa"])
        figs["flutter_mode_shape"] = figure_of(shape.plot())
    return Outcome(status, s, arr, figs, res)


def _truncation(spec, opts, res) -> dict:
    """Truncation error of the headline speeds: ``n`` against ``n + 8`` retained modes.

    :func:`bridgeflap.model.stability.convergence.truncation_error` (the step of 8 spans the next
    symmetric torsional mode on Humber); the ``n``-mode sweep is not repeated.
    """
    from bridgeflap.model.stability.convergence import truncation_error

    s = res.summary()
    # the modes actually retained (an imported modal model may hold fewer than asked)
    t = truncation_error(spec, int(s["modes_retained"]), grid(opts["speeds"], "speeds", 0.0),
                         rfa=opts["rfa"], at_n=res.sweep.summary(),
                         sweep_method=s.get("sweep_method", opts["sweep"]))  # as the n-mode one
    if t["reference_modes"] == t["n_modes"]:  # the model holds no further mode to add
        return {"truncation_reference_modes": t["reference_modes"],
                "flutter_truncation_error_pct": None, "divergence_truncation_error_pct": None,
                "truncation_status": "all_modes_retained"}
    return {"truncation_reference_modes": t["reference_modes"],
            "flutter_truncation_error_pct": t["flutter_truncation_error_pct"],
            "divergence_truncation_error_pct": t["divergence_truncation_error_pct"],
            "truncation_status": t["truncation_status"]}


_FLUTTER_CASE_KEYS = ("flutter_speed_m_s", "flutter_frequency_hz", "flutter_status",
                      "divergence_speed_m_s", "divergence_status", "divergence_static_speed_m_s",
                      "divergence_static_status", "critical_speed_m_s", "critical_mechanism",
                      "critical_branch_label", "critical_branch_label_source",
                      "second_critical_branch_label", "second_flutter_speed_m_s",
                      "second_flutter_status", "flutter_onset")
#: present only with ``truncation_check = true`` (None otherwise)
_TRUNCATION_KEYS = ("flutter_truncation_error_pct", "divergence_truncation_error_pct",
                    "truncation_status")


def _flutter_case(outcome: Outcome) -> dict:
    return {**{k: outcome.summary[k] for k in _FLUTTER_CASE_KEYS},
            **{k: outcome.summary.get(k) for k in _TRUNCATION_KEYS}}


def _run_erection(spec, opts, context) -> Outcome:
    from bridgeflap.model.analysis import erection

    fractions = grid(opts["fractions"], "fractions")
    res = erection(spec, fractions,
                   grid(opts["speeds"], "speeds", 0.0), int(opts["modes"]),
                   progress=counted(len(fractions), context.say,
                                    lambda f, k: f"erection stage {f:.3f} done "
                                                 f"({k}/{len(fractions)})"),
                   side_spans=opts["side_spans"] or None, workers=context.workers)
    bad = [st for st in res.stages if st["flutter_status"] != "converged"]
    status = "ok" if not bad else (f"{len(bad)} of {len(res.stages)} stages: flutter "
                                   + ", ".join(sorted({st['flutter_status'] for st in bad})))
    arr = {k: np.array([np.nan if st.get(k) is None else st.get(k, np.nan)
                        for st in res.stages], dtype=float)
           for k in ("erected_fraction", "flutter_speed_m_s", "divergence_speed_m_s")}
    return Outcome(status, res.summary(), arr, _figures(context, "erection", res), res)


def _run_sensitivity(spec, opts, context) -> Outcome:
    # design/sensitivity/local.py (H1): one import line
    from bridgeflap.design.sensitivity.local import local_sensitivity

    params = opts["parameters"]
    n = len([p for p in params.split(",") if p.strip()] if isinstance(params, str) else params)
    res = local_sensitivity(spec, params, speeds=grid(opts["speeds"], "speeds", 0.0),
                            n_modes=int(opts["modes"]), check=bool(opts["check"]),
                            progress=counted(n, context.say,
                                             lambda p, k: f"sensitivity: {p} done ({k}/{n})"))
    bad = [r["parameter"] for r in res.rows
           if r["flutter_status"] != "ok" or r["divergence_status"] != "ok"]
    status = "ok" if not bad else f"IFT not available for {', '.join(bad)}"
    return Outcome(status, res.summary(), {}, _figures(context, "sensitivity", res), res)


#: options of :func:`model.response.buffeting.buffeting` a study or DOE file may set (``modes`` is
# its
#: ``n_modes``)
_BUFFETING_OPTIONS = ("speeds", "modes", "spectrum", "admittance", "coherence_decay", "method",
                      "turbulence_intensity", "deck_height_m", "length_scale_m", "half_chord_m",
                      "allow_unstable", "omega_max", "n_base", "peaks_per_mode", "half_widths",
                      "convergence_tol", "mc_records", "mc_seed", "mc_points")


def _run_buffeting(spec, opts, context) -> Outcome:
    from bridgeflap.model.response.buffeting import buffeting

    opts = dict(opts)
    speeds = grid(opts.pop("speeds"), "buffeting.speeds", 0.0)
    res = buffeting(spec, speeds, n_modes=int(opts.pop("modes")), **opts)
    s = res.summary()
    arr = {k: np.asarray(s[k], dtype=float) for k in ("speeds_m_s", "rms_vertical_m",
                                                      "rms_vertical_over_width") if k in s}
    return Outcome(aggregate_status(s.get("status", "unknown")), s, arr,
                   _figures(context, "buffeting", res), res)


def _buffeting_case(outcome: Outcome) -> dict:
    rms = np.asarray(outcome.summary.get("rms_vertical_m", []), dtype=float)
    return {"max_rms_vertical_m": float(np.nanmax(rms)) if rms.size else float("nan"),
            "status": outcome.summary.get("status", "unknown")}


def design_settings(opts: Mapping, bridge: str | None):
    """The study's design settings: ``card`` (a packaged card of ``design/studies``, e.g.
    ``"humber_flaps.toml"`` -- the one `bridgeflap optimise` runs by default --, or a path)
    with the other options as overrides; without a card the settings' defaults, the study's
    bridge and the options. With a card its own bridge is kept unless ``bridge`` is among the
    options, so that the study and `bridgeflap optimise` design the same controller."""
    from bridgeflap.design.control.settings import load_settings, packaged_card

    opts = dict(opts)
    card = opts.pop("card", None)
    if card is None:
        return load_settings(None, **({"bridge": bridge} if bridge else {}), **opts)
    if not isinstance(card, str) or not card:
        raise BridgeflapInputError("card", f"must be a card name or path, got {card!r}")
    return load_settings(packaged_card(card), **opts)


def _run_design(spec, opts, context) -> Outcome:
    from bridgeflap.design.assessment.accept import design
    from bridgeflap.design.control.settings import quick_settings

    # an in-memory bridge goes to the design as its spec (settings.bridge: its name if that
    # loads, else the default; the controller's plant record hashes the spec); with a card,
    # the spec replaces the card's bridge
    mem = isinstance(context.bridge, BridgeSpec) and "bridge" not in opts
    name = context.bridge.name if mem else context.bridge
    if mem and name.split(":")[0] not in BUILTIN_BRIDGES:
        name = "humber"
    settings = design_settings({**opts, "bridge": name} if mem else opts, name)
    if context.quick:
        settings = quick_settings(settings)
    # the design with the acceptance checks of `bridgeflap optimise`, folded into its status
    # (harm is never "converged": design.assessment.accept)
    res = design(settings, progress=lambda msg: context.say(f"  design: {msg}"),
                 bridge=context.bridge if mem else None, quick_checks=context.quick,
                 check_workers=context.workers)
    s = res.summary()
    figs = {}
    # the candidate of a design that is not usable is drawn too, marked so (design.studies.
    # figures.fig5 status): its Fig. 5 is what tells why
    ctrl = res.controller if res.controller is not None else res.candidate
    if context.figures and ctrl is not None:
        context.say("  design: closed-loop root locus and buffeting (Fig. 5)")
        # on the bridge the controller was designed for (the study's [design] may name a
        # variant), on the study's mesh
        from bridgeflap.model.structure.loader import load_bridge

        dspec = load_bridge(context.bridge if mem else settings.bridge).replace(
            **{"mesh.element_length_m": spec.mesh.element_length_m})
        figs["design"] = fig5(dspec, ctrl, n_modes=settings.n_modes,
                              quick=context.quick, open_loop_flutter_m_s=(
                                  s.get("closed_loop_limits") or {}).get(
                                      "open_loop_flutter_speed_m_s"), status=res.status)
        if s.get("response_by_speed"):
            from bridgeflap.design.assessment.usable_speed import plot_response

            figs["design_response"] = plot_response(
                s["response_by_speed"], res.usable_speed(),
                title=f"deck response and flap demand (design {res.status})")
        figs["design_margins"] = figure_of(res.plot_margins())
        figs["design_bode"] = figure_of(res.plot_bode())
    return Outcome(aggregate_status(s.get("status", "unknown")), s, {}, figs, res)


def _table(**entries) -> Mapping:
    return MappingProxyType(entries)


#: every analysis, by name: the CLI, studies and DOE cases take their defaults from here
ANALYSES: Mapping[str, Analysis] = _table(
    modes=Analysis("modes", _run_modes, _table(count=30), ("count",), _modes_case),
    frequency_ratio=Analysis("frequency_ratio", _run_frequency_ratio,
                             _table(fractions="0.1:1.0:0.05", side_spans=""),
                             ("fractions", "side_spans")),
    flutter=Analysis("flutter", _run_flutter,
                     _table(speeds=DEFAULT_SPEEDS, modes=DEFAULT_MODES, rfa="rfa4",
                            order="modal", truncation_check=True, sweep="fast"),
                     ("speeds", "modes", "rfa", "order", "truncation_check", "sweep"),
                     _flutter_case),
    erection=Analysis("erection", _run_erection,
                      _table(fractions="0.1:1.0:0.1", speeds=DEFAULT_SPEEDS,
                             modes=DEFAULT_MODES, side_spans=""),
                      ("fractions", "speeds", "modes", "side_spans")),
    buffeting=Analysis("buffeting", _run_buffeting,
                       _table(speeds="4:25:1", modes=DEFAULT_MODES), _BUFFETING_OPTIONS,
                       _buffeting_case),
    sensitivity=Analysis("sensitivity", _run_sensitivity,
                         _table(parameters=DEFAULT_PARAMETERS, speeds="0:120:1",
                                modes=DEFAULT_MODES, check=True),
                         ("parameters", "speeds", "modes", "check")),
    design=Analysis("design", _run_design, _table(), None),
)


def fig5(spec, controller, n_modes: int = DEFAULT_MODES, quick: bool = False,
         open_loop_flutter_m_s: float | None = None, status: str | None = None):
    """The paper's Fig. 5: closed-loop root locus 0-85 m/s over the open loop (left), vertical and
    torsional buffeting with and without the flaps (the open loop is NaN beyond its flutter
    speed, never clipped). ``open_loop_flutter_m_s`` is the marked open-loop flutter speed
    (the design result's own; default: this figure's open-loop sweep)."""
    from bridgeflap.design.studies.figures import fig5 as draw
    from bridgeflap.model.analysis import closed_loop_flutter
    from bridgeflap.model.response.buffeting import buffeting

    speeds = parse_range("0:85:1" if quick else DEFAULT_SPEEDS, "speeds", 0.0)
    cl = closed_loop_flutter(spec, controller, speeds, n_modes)
    bspeeds = np.arange(4.0, 84.0 + 1e-9, 8.0 if quick else 4.0)
    ol = buffeting(spec, bspeeds, n_modes=n_modes, allow_unstable=True)
    clb = buffeting(spec, bspeeds, n_modes=n_modes, controller=controller, allow_unstable=True)
    return draw(cl.base.sweep, cl.open_loop.sweep, ol, clb, controller, open_loop_flutter_m_s,
                model_text=f"the paper's Fig. 5 analogue: {spec.name}, {n_modes} modes",
                status=status)
