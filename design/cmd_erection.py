"""``bridgeflap erection``: flutter/divergence against the erected fraction (seed Fig. 3
right), and with ``--controller`` the closed loop of each stage with the flaps on its deck
(issue 27 item 4, :mod:`design.erection_control`)."""

from __future__ import annotations

from design.cli_common import (
    add_common,
    check_plot_target,
    controller_from_args,
    default_workers,
    emit,
    log,
    save_plot,
)
from design.options import parse_range
from model.results import table_text
from model.spec import SIDE_SPAN_SEQUENCES

__all__ = ["arguments", "cmd_erection"]

_SIDE_SPANS_HELP = "side-span decks while erecting: bare, in_place, with_main (default: file's)"


def cmd_erection(args):
    """Open-loop stages, or open- and closed-loop stages with ``--controller``."""
    from design.cli import _run
    from model.spec import load_bridge

    check_plot_target(args)
    spec = load_bridge(args.bridge)
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


def _closed_loop(args, spec):
    from design.erection_control import erection_closed_loop

    if args.plot:
        from model.errors import BridgeflapInputError

        raise BridgeflapInputError("--plot", "not available with --controller (the table and "
                                   "the JSON carry the closed loop per stage)")
    controller = controller_from_args(args, spec)
    fractions = parse_range(args.fractions, "fractions", None, None)
    speeds = parse_range(args.speeds, "speeds", 0.0)
    log(f"erection with flaps: {len(fractions)} stages + the completed bridge, "
        f"{len(controller.flap_strip_positions_m)} flap strips in the file")
    res = erection_closed_loop(spec, controller, fractions, speeds, args.modes,
                               side_spans=args.side_spans or None)
    cols = ["erected_fraction", "flap_strips_on_deck", "open_loop_critical_speed_m_s",
            "open_loop_critical_mechanism", "closed_loop_critical_speed_m_s",
            "closed_loop_critical_mechanism", "closed_over_open", "stage"]
    s = res.summary()
    s["controller_file"] = str(args.controller)
    lines = [f"side spans while erecting: {res.side_spans}; flaps: the controller's strips on "
             "the erected deck",
             table_text(res.to_dataframe()[cols], "simple"),
             f"status {s['status']}; worst closed-loop stage "
             f"{s['worst_stage_erected_fraction']} at {s['worst_closed_loop_critical_speed_m_s']}"
             " m/s"]
    emit(args, s, "\n".join(lines))
    return 0


def arguments(sp) -> None:
    """The options of ``bridgeflap erection``."""
    from design.cli import _default

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
    sp.add_argument("--workers", type=int, default=default_workers(),
                    help="worker processes for the stages (default: min(2, CPU count))")
