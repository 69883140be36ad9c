"""``bridgeflap placement``: the fewest flap strips, and where, that meet a target speed.

``bridgeflap placement [definition.toml] [--quick] [--target-m-s U] [--max-steps N]
[--workers N] [--out DIR] [--json]`` runs
:func:`bridgeflap.design.control.search.placement.placement_search` on the card's candidate
strips: K(s) re-optimised for every layout, greedy backward elimination over mirror groups,
every layout judged on the design's own verification, the actuator demand at the target, the
scenario bridges and one strip failed. It prints the trade-off (strips -> critical speed, max
gain, flap demand) and the chosen layout's ``flap_positions_m`` line for the card. ``--out``
writes ``placement.json`` (what ``--json`` prints), ``tradeoff.csv`` and ``placement.png``,
swapped into place whole. Exit 0 when a layout meets the target (``found``), 1 otherwise.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

from bridgeflap.design.cli.common import (
    add_common,
    check_output_folder,
    default_workers,
    emit,
    log,
    save_figure,
)
from bridgeflap.model.errors import BridgeflapInputError

__all__ = ["arguments", "cmd_placement"]

DEFAULT_DEFINITION = "default"


def cmd_placement(args):
    """Run the placement search and report it."""
    import math

    from bridgeflap.design.control.search.placement import placement_search
    from bridgeflap.design.control.settings import load_settings, quick_settings
    from bridgeflap.model.structure.loader import load_bridge

    if args.definition is not None and not Path(args.definition).is_file():
        raise BridgeflapInputError("definition", f"not a file: {args.definition}")
    if args.target_m_s is not None and not (math.isfinite(args.target_m_s)
                                            and 0.0 < args.target_m_s <= 200.0):
        raise BridgeflapInputError("target-m-s", f"must be a speed in (0, 200] m/s, got "
                                                 f"{args.target_m_s}")
    if not 1 <= args.workers <= 1024:
        raise BridgeflapInputError("workers", f"must be an integer in [1, 1024], got "
                                              f"{args.workers}")
    if args.max_steps is not None and not 0 <= args.max_steps <= 1000:
        raise BridgeflapInputError("max-steps", f"must be an integer in [0, 1000], got "
                                                f"{args.max_steps}")
    settings = load_settings(args.definition or DEFAULT_DEFINITION)
    if args.quick:
        settings = quick_settings(settings)
    if not settings.actuator_design_speeds_m_s:
        raise BridgeflapInputError("definition", "the card sets no actuator_design_speeds_m_s: "
                                                 "the placement judges layouts on their flap "
                                                 "demand")
    out = None
    if args.out:
        from bridgeflap.design.io.outputs import check_replaceable

        out = Path(args.out)
        check_output_folder("out", out)
        out = check_replaceable(out, "out", "placement")
    load_bridge(settings.bridge)  # bad bridge input stops here, before the search runs
    if out is None:
        return _run(args, settings, None, placement_search)
    from bridgeflap.design.io.outputs import claim_output

    with claim_output(out, "out", kind="placement"):
        return _run(args, settings, out, placement_search)


def _run(args, settings, out, search):
    res = search(settings, target_m_s=args.target_m_s, log=log, workers=args.workers,
                 max_steps=args.max_steps)
    payload = res.summary()
    if out is not None:
        _write(res, payload, out)
        payload["out"] = str(out)
    c = res.chosen_row
    lines = [f"placement on {settings.bridge}: target {res.target_m_s:.2f} m/s "
             f"({res.target_basis}), {len(res.rows)} layouts tried in {res.time_s:.0f} s, "
             f"status {res.status}", res.table()]
    if c is not None:
        speeds = payload["settings"]["actuator_design_speeds_m_s"]
        lines.append(f"chosen: {c.strips} strips; for the card: flap_positions_m = "
                     f"[{', '.join(f'{x:g}' for x in c.flap_positions_m)}], "
                     f"actuator_design_speeds_m_s = [{', '.join(f'{u:g}' for u in speeds)}]")
    else:
        r = res.rows[0]
        lines.append(f"no layout meets the target; every candidate strip: "
                     f"{'; '.join(r.why_not) or r.status}")
    emit(args, payload, "\n".join(lines))
    return 0 if res.status == "found" else 1


def _write(res, payload, out: Path) -> None:
    """``placement.json``, ``tradeoff.csv`` and ``placement.png`` into ``out``, whole."""
    import csv
    import io

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from bridgeflap.design.io.files import atomic_write_text, to_jsonable
    from bridgeflap.design.io.outputs import swap_into_place, temporary_sibling, write_marker
    from bridgeflap.model.results import figure_of

    tmp = temporary_sibling(out)
    try:
        tmp.mkdir()
        write_marker(tmp, "placement")
        atomic_write_text(tmp / "placement.json",
                          json.dumps(to_jsonable({**payload, "out": str(out)}),
                                     allow_nan=False))
        buf = io.StringIO()
        keys = ("strips", "kind", "meets_target", "stable_to_m_s", "max_gain",
                "flap_angle_3sigma_at_target_deg", "flap_rate_3sigma_at_target_deg_s",
                "failed_strip_stable_to_m_s", "robust_margin", "flap_positions_m")
        w = csv.writer(buf, lineterminator="\n")
        w.writerow(keys)
        for t in res.tradeoff():
            w.writerow([" ".join(f"{x:g}" for x in t[k]) if k == "flap_positions_m" else t[k]
                        for k in keys])
        atomic_write_text(tmp / "tradeoff.csv", buf.getvalue())
        fig = figure_of(res.plot())
        save_figure(fig, tmp / "placement.png")
        plt.close(fig)
        swap_into_place(tmp, out)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def arguments(sp) -> None:
    """The options of ``bridgeflap placement``."""
    add_common(sp, bridge=False, erection=False)
    sp.add_argument("definition", nargs="?", default=None,
                    help="design definition .toml (default: the packaged copy of "
                         "runs/humber_flaps.toml); its candidates are flap_count evenly "
                         "spaced strips")
    sp.add_argument("--quick", action="store_true",
                    help="the reduced settings of optimise --quick for every layout (about "
                         "25 s of CPU per layout on the packaged card)")
    sp.add_argument("--target-m-s", dest="target_m_s", type=float, default=None,
                    help="target speed [m/s] (default: the open-loop divergence speed + 1 %%)")
    sp.add_argument("--max-steps", dest="max_steps", type=int, default=None,
                    help="at most this many removal steps (default: until none meets the "
                         "target)")
    sp.add_argument("--workers", type=int, default=default_workers(),
                    help="worker processes for the layouts of a step (default: min(2, CPUs))")
    sp.add_argument("--out", default=None,
                    help="output folder: placement.json, tradeoff.csv, placement.png")
