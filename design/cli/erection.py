"""``bridgeflap erection``: flutter/divergence against the erected fraction (the paper's Fig. 3
right), and with ``--controller`` the closed loop of each stage with the flaps on its deck
(:mod:`bridgeflap.design.assessment.erection_control`)."""

from __future__ import annotations

from bridgeflap.design.cli.common import (
    add_common,
    check_plot_target,
    controller_from_args,
    default_workers,
    emit,
    log,
    save_plot,
)
from bridgeflap.design.io.options import parse_range
from bridgeflap.model.errors import BridgeflapInputError
from bridgeflap.model.results import table_text
from bridgeflap.model.structure.spec import SIDE_SPAN_SEQUENCES

__all__ = ["arguments", "cmd_erection"]

_SIDE_SPANS_HELP = "side-span decks while erecting: bare, in_place, with_main (default: file's)"


def cmd_erection(args):
    """Open-loop stages, or open- and closed-loop stages with ``--controller``."""
    from bridgeflap.design.cli.main import _run
    from bridgeflap.model.structure.loader import load_bridge

    check_plot_target(args)
    for option, given in (("--card", args.card), ("--save-controller", args.save_controller)):
        if given is not None and args.design_stage is None:
            raise BridgeflapInputError(option, "only with --design-stage (the stage design's "
                                               "card and controller file)")
    spec = load_bridge(args.bridge)
    if args.design_stage is not None:
        return _design_stage(args, spec)
    if args.controller:
        return _closed_loop(args, spec)
    res = _run("erection", spec, fractions=args.fractions,
               speeds=args.speeds, modes=args.modes, side_spans=args.side_spans or "",
               workers=args.workers)
    cols = ["erected_fraction", "flutter_speed_m_s", "flutter_status", "divergence_speed_m_s",
            "divergence_status", "stage"]
    lines = [f"side spans while erecting: {res.side_spans}",
             table_text(res.to_dataframe()[cols], "simple")]
    if args.plot:
        save_plot(res, args.plot)
    emit(args, res.summary(), "\n".join(lines))
    return 0


_CL_COLS = ["erected_fraction", "flap_strips_on_deck", "open_loop_critical_speed_m_s",
            "open_loop_critical_mechanism", "closed_loop_critical_speed_m_s",
            "closed_loop_critical_mechanism", "closed_over_open", "stage"]


def _no_plot(args, option):
    if args.plot:
        from bridgeflap.model.errors import BridgeflapInputError

        raise BridgeflapInputError("--plot", f"not available with {option} (the table and "
                                   "the JSON carry the closed loop per stage)")


def _closed_loop(args, spec):
    from bridgeflap.design.assessment.erection_control import erection_closed_loop

    _no_plot(args, "--controller")
    controller = controller_from_args(args, spec)
    fractions = parse_range(args.fractions, "fractions", None, None)
    speeds = parse_range(args.speeds, "speeds", 0.0)
    res = erection_closed_loop(spec, controller, fractions, speeds, args.modes,
                               side_spans=args.side_spans or None, progress=log)
    s = res.summary()
    s["controller_file"] = str(args.controller)
    lines = [f"side spans while erecting: {res.side_spans}; flaps: the controller's strips on "
             "the erected deck",
             table_text(res.to_dataframe()[_CL_COLS], "simple"),
             f"status {s['status']}; worst closed-loop stage "
             f"{s['worst_stage_erected_fraction']} at {s['worst_closed_loop_critical_speed_m_s']}"
             " m/s"]
    emit(args, s, "\n".join(lines))
    return 0


def _check_save_target(path) -> None:
    """``--save-controller``: a file whose folder exists and is writable, checked before the
    design (minutes) runs."""
    import os
    from pathlib import Path

    from bridgeflap.model.errors import BridgeflapInputError

    p = Path(path)
    if p.is_dir():
        raise BridgeflapInputError("--save-controller", f"is a folder, not a file: {p}")
    parent = p.resolve().parent
    if not parent.is_dir():
        raise BridgeflapInputError("--save-controller", f"folder does not exist: {parent}")
    if not os.access(parent, os.W_OK) or not parent.stat().st_mode & 0o222:
        raise BridgeflapInputError("--save-controller", f"folder not writable: {parent}")


def _design_stage(args, spec):
    """``--design-stage``: a controller designed for one stage (the worst open-loop one by
    default), then every stage's closed loop with its strips
    (bridgeflap.design.assessment.erection_control)."""
    from bridgeflap.design.assessment.erection_control import design_for_stage, erection_closed_loop
    from bridgeflap.model.arguments import check_number
    from bridgeflap.model.errors import BridgeflapInputError

    _no_plot(args, "--design-stage")
    if args.controller:
        raise BridgeflapInputError("--design-stage", "designs its own controller: give it "
                                   "without --controller")
    fractions = parse_range(args.fractions, "fractions", None, None)
    speeds = parse_range(args.speeds, "speeds", 0.0)
    side = args.side_spans or None
    worst_open = None
    if args.design_stage != "worst":  # checked before any work or progress line
        try:
            fraction = check_number(float(args.design_stage), "--design-stage", 0.0, 1.0,
                                    strict=True)
        except (ValueError, BridgeflapInputError):
            raise BridgeflapInputError("--design-stage", "'worst' or an erected fraction in "
                                       f"(0, 1], got {args.design_stage!r}") from None
    if args.card is not None:   # the card and the controller's target before any work
        from bridgeflap.design.control.settings import load_settings, packaged_card

        load_settings(packaged_card(args.card))
    if args.save_controller:
        _check_save_target(args.save_controller)
    from bridgeflap.design.assessment.erection_control import (
        check_stage_modes,
        stage_design_count,
    )

    # the stages' closed loops after the design need --modes: checked before it runs
    check_stage_modes(spec, fractions, args.modes, side)
    if args.design_stage != "worst":
        stage_design_count(spec, fraction, args.card)  # a flap strip fits: before any line
    if args.design_stage == "worst":
        from bridgeflap.design.studies.analyses import ANALYSES, RunContext

        # the open-loop stages' progress lines wait for the verdict on --design-stage: a
        # refusal (no stage has a critical speed) prints its one line only
        held: list[str] = []
        entry = ANALYSES["erection"]
        ol = entry.run(spec, {**entry.defaults, "fractions": args.fractions,
                              "speeds": args.speeds, "modes": args.modes,
                              "side_spans": args.side_spans or ""},
                       RunContext(figures=False, progress=held.append,
                                  workers=args.workers)).result
        rows = ol.to_dataframe()
        crit = rows[["flutter_speed_m_s", "divergence_speed_m_s"]].min(axis=1)
        if crit.notna().sum() == 0:
            raise BridgeflapInputError("--design-stage", "no stage has a critical speed on "
                                       "the --speeds grid: give a fraction")
        i = int(crit.idxmin())
        stage_design_count(spec, float(rows["erected_fraction"][i]), args.card)
        for line in held:
            log(line)
        i = int(crit.idxmin())
        fraction, worst_open = float(rows["erected_fraction"][i]), float(crit[i])
    log(f"designing for the stage erected {fraction:g} (critical-speed objective)")
    res = design_for_stage(spec, fraction, card=args.card, progress=log, side_spans=side)
    summ = res.summary()
    out = {"design_stage_erected_fraction": fraction,
           "design_stage_open_loop_critical_speed_m_s": worst_open,
           "design_status": res.status, "controller_usable": res.controller is not None,
           "design": {k: summ.get(k) for k in ("coefficients", "flap_count",
                                               "flap_positions_m", "max_gain", "gain_limit",
                                               "robust_margin", "critical_speed",
                                               "closed_loop_limits", "best_achievable")
                      if k in summ},
           "controller_file": None, "stages": [], "status": res.status}
    lines = [f"design for the stage erected {fraction:g}: {res.status}"]
    if res.controller is not None:
        if args.save_controller:
            from bridgeflap.model.aeroelastic.controller_file import save_controller

            out["controller_file"] = str(save_controller(res.controller, args.save_controller))
        cl = erection_closed_loop(spec, res.controller, fractions, speeds, args.modes,
                                  side_spans=side)
        out |= {k: v for k, v in cl.summary().items() if k != "status"}
        out["stages_status"] = cl.status
        lines += [table_text(cl.to_dataframe()[_CL_COLS], "simple"),
                  f"worst closed-loop stage {out['worst_stage_erected_fraction']} at "
                  f"{out['worst_closed_loop_critical_speed_m_s']} m/s; controller file "
                  f"{out['controller_file']}"]
    else:
        lines.append("no usable stage controller (design.best_achievable in --json)")
    emit(args, out, "\n".join(lines))
    return 0 if res.controller is not None else 1


def arguments(sp) -> None:
    """The options of ``bridgeflap erection``."""
    from bridgeflap.design.cli.main import _default

    add_common(sp, erection=False)
    sp.add_argument("--fractions", default=_default("erection", "fractions"),
                    help="erected fractions of the main span, start:stop:step or a list")
    sp.add_argument("--speeds", default=_default("erection", "speeds"),
                    help="wind speeds [m/s], start:stop:step")
    sp.add_argument("--modes", type=int, default=_default("erection", "modes"),
                    help="retained vertical + torsional modes")
    sp.add_argument("--side-spans", choices=SIDE_SPAN_SEQUENCES, default=None,
                    help=_SIDE_SPANS_HELP)
    sp.add_argument("--plot", default=None, help="figure file (.png/.pdf/.svg)")
    sp.add_argument("--controller", default=None,
                    help="controller .toml: each stage's closed loop with the flaps on its deck")
    sp.add_argument("--design-stage", default=None, metavar="worst|FRACTION",
                    help="design a controller for one stage (the worst open-loop one, or an "
                         "erected fraction in (0, 1]) on the strips that fit on its deck, "
                         "maximising its closed-loop critical speed; then every stage with it")
    sp.add_argument("--card", default=None,
                    help="design card .toml for --design-stage (default: the packaged card)")
    sp.add_argument("--save-controller", default=None, metavar="PATH",
                    help="with --design-stage: write the stage controller .toml here")
    sp.add_argument("--workers", type=int, default=default_workers(),
                    help="worker processes for the stages (default: min(2, CPU count))")
