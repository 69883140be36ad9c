"""``bridgeflap robustness``: do no harm -- a controller on fresh bridge variants (issue 28).

``bridgeflap robustness --controller controller.toml [--samples 200] [--seed 11] [--modes 30]
[--speed-max 85] [--workers 2] [--out table.csv] [--json]`` samples ``--samples`` variants over
the estimated-input ranges (:mod:`design.harm`), runs each open and closed loop on the same grid
and prints the fraction stable to the design speed, the fraction *harmed* (closed-loop critical
speed below the variant's own open-loop one), the worst closed/open ratio and the status
(``no_harm``, ``harm``, or ``unresolved`` when a crossing is not verified). Exit status 0 for
``no_harm``, 1 otherwise (a result, but not a controller to use as it is); ``--out`` writes the
per-variant table (CSV).
"""

from __future__ import annotations

from pathlib import Path

from design.cli_common import add_common, controller_from_args, default_workers, emit, log
from model.errors import BridgeflapInputError

__all__ = ["arguments", "cmd_robustness"]


def cmd_robustness(args):
    """Run the do-no-harm check of ``--controller`` and report it."""
    from design.cli_common import check_writable_parent
    from design.harm import do_no_harm
    from model.spec import load_bridge

    if not args.controller:
        raise BridgeflapInputError("controller", "a controller .toml is required")
    if not args.speed_max > 0:
        raise BridgeflapInputError("speed-max", f"must be positive, got {args.speed_max}")
    if args.out:
        if not str(args.out).lower().endswith(".csv"):
            raise BridgeflapInputError("out", f"expected a .csv file, got {args.out}")
        check_writable_parent("out", Path(args.out))
    spec = load_bridge(args.bridge)
    controller = controller_from_args(args, spec)
    res = do_no_harm(controller, args.bridge, count=args.samples, seed=args.seed,
                     n_modes=args.modes, speed_max_m_s=args.speed_max, workers=args.workers,
                     progress=log)  # progress on stderr, also with --json
    s = res.summary()
    if args.out:
        from design.io import atomic_write_text

        atomic_write_text(args.out, res.to_dataframe().to_csv(index=False))
        s["table"] = str(args.out)
    worst = s["worst_closed_over_open"]
    text = (f"{s['bridge']}: {s['variants']} variants ({s['modes']} modes): "
            f"{100 * s['fraction_stable_to_design_speed']:.1f} % stable to "
            f"{s['design_speed_m_s']:g} m/s, {100 * s['fraction_harmed']:.1f} % harmed, "
            f"worst closed/open {'n/a' if worst is None else f'{worst:.4f}'}, "
            f"{s['unresolved_variants']} unresolved: {s['status']}")
    emit(args, s, text)
    return 0 if s["status"] == "no_harm" else 1


def arguments(sp) -> None:
    """The options of ``bridgeflap robustness``."""
    add_common(sp, erection=False)
    sp.add_argument("--controller", default=None,
                    help="controller .toml to judge (its own flap chord and layout)")
    sp.add_argument("--samples", type=int, default=200,
                    help="fresh variants (Sobol' sample of the estimated-input ranges)")
    sp.add_argument("--seed", type=int, default=11, help="Sobol' scramble seed")
    sp.add_argument("--modes", type=int, default=30, help="retained modes of every variant")
    sp.add_argument("--speed-max", type=float, default=85.0,
                    help="design speed [m/s]: 'stable to the design speed' is above it")
    sp.add_argument("--workers", type=int, default=default_workers(),
                    help="worker processes (default: min(2, CPUs))")
    sp.add_argument("--out", default=None, help="per-variant table (.csv)")
