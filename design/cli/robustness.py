"""``bridgeflap robustness``: do no harm -- a controller on fresh bridge variants.

``bridgeflap robustness --controller controller.toml [--samples 200] [--seed 11] [--modes 30]
[--speed-max 85] [--workers 2] [--scheduler ADDRESS|local] [--method fast|reference]
[--screen-modes 16] [--out table.csv]
[--json]`` samples ``--samples`` variants over
the estimated-input ranges (:mod:`bridgeflap.design.assessment.harm`), runs each open and closed
loop on the same grid and prints the fraction stable to the design speed, the fraction *harmed*
(closed-loop critical speed below the variant's own open-loop one), the worst closed/open ratio and
the status (``no_harm``, ``harm``, or ``unresolved`` when a crossing is not verified). Exit status 0
for ``no_harm``, 1 otherwise (a result, but not a controller to use as it is); ``--out`` writes the
per-variant table (CSV). ``--method fast`` (default) screens each variant on
``--screen-modes`` modes and recomputes on ``--modes`` the rows near a decision or an extreme
(:func:`bridgeflap.design.assessment.harm.do_no_harm`; ``--screen-modes 0``: no screening);
``--method reference`` runs the full sweeps of every variant on ``--modes``.

``--failures [--stuck-angle-deg 5]`` judges the controller on its own bridge with each single
flap pair failed instead (:mod:`bridgeflap.design.assessment.failsafe`): stuck at 0, stuck at an
angle (the same linear stability, plus its static deflection) and the controller off, each with its
critical speed, mechanism, status and ratios to the intact and the open loop; exit 0 for
``single_failure_safe``, 1 otherwise; ``--out`` writes the per-pair table. The options of the
fresh variants (``--samples``, ``--seed``, ``--sampling``, ``--method``, ``--screen-modes``,
``--scheduler``) are refused with ``--failures``.
"""

from __future__ import annotations

from pathlib import Path

from bridgeflap.design.assessment.harm import DEFAULT_SCREEN_MODES, HARM_METHODS, SAMPLINGS
from bridgeflap.design.cli.common import (
    add_common,
    controller_from_args,
    default_workers,
    emit,
    log,
)
from bridgeflap.design.io.api_args import MAX_VARIANTS
from bridgeflap.model.errors import BridgeflapInputError

__all__ = ["DEFAULT_SAMPLES", "DEFAULT_SEED", "arguments", "cmd_robustness"]

#: fresh variants of ``bridgeflap robustness`` when ``--samples`` is not given
DEFAULT_SAMPLES = 200
#: seed of the draws when ``--seed`` is not given
DEFAULT_SEED = 11


def cmd_robustness(args):
    """Run the do-no-harm check of ``--controller`` and report it."""
    from bridgeflap.design.assessment.harm import do_no_harm
    from bridgeflap.design.cli.common import check_writable_parent
    from bridgeflap.design.io.api_args import check_design_speed, check_scheduler
    from bridgeflap.model.structure.loader import load_bridge

    if not args.controller:
        raise BridgeflapInputError("controller", "a controller .toml is required")
    # the bounds of do_no_harm's own arguments (design.io.api_args), also checked after parsing
    check_design_speed(args.speed_max, "speed-max")
    check_scheduler(args.scheduler, "scheduler")
    if args.screen_modes is not None and args.screen_modes < 0:
        raise BridgeflapInputError("screen-modes", f"must be >= 0, got {args.screen_modes}")
    if args.screen_modes and args.screen_modes >= args.modes:
        # the screening sweep would have as many modes as the reference: nothing screened
        raise BridgeflapInputError("screen-modes", f"must be below --modes ({args.modes}), got "
                                                   f"{args.screen_modes} (0: no screening)")
    if args.screen_modes is not None and args.method == "reference":
        raise BridgeflapInputError("screen-modes", "not with --method reference (the full "
                                                   "sweeps on --modes, never screened)")
    if args.stuck_angle_deg is not None and not args.failures:
        raise BridgeflapInputError("stuck-angle-deg", "only with --failures")
    if args.failures:
        # the failure table is one bridge's few sweeps, run here: a cluster is not used
        for option, given in (("scheduler", args.scheduler is not None),
                              ("sampling", args.sampling is not None),
                              ("samples", args.samples is not None),
                              ("seed", args.seed is not None),
                              ("method", args.method is not None),
                              ("screen-modes", args.screen_modes is not None)):
            if given:
                raise BridgeflapInputError(option, "not with --failures (the single-pair "
                                                   "failure table runs on this machine's "
                                                   "--workers, on the controller's own bridge)")
    if args.out:
        if not str(args.out).lower().endswith(".csv"):
            raise BridgeflapInputError("out", f"expected a .csv file, got {args.out}")
        check_writable_parent("out", Path(args.out))
    if args.failures:
        return _failures(args)
    spec = load_bridge(args.bridge)
    from bridgeflap.design.io.api_args import check_model_modes

    check_model_modes(spec, args.modes, "modes")  # before the first progress line
    controller = controller_from_args(args, spec)
    res = do_no_harm(controller, args.bridge, count=DEFAULT_SAMPLES if args.samples is None
                     else args.samples, seed=DEFAULT_SEED if args.seed is None else args.seed,
                     n_modes=args.modes, speed_max_m_s=args.speed_max, workers=args.workers,
                     progress=log,  # progress on stderr, also with --json
                     method=args.method or "fast",
                     screen_modes=(DEFAULT_SCREEN_MODES if args.screen_modes is None
                                   else args.screen_modes or None),
                     scheduler=args.scheduler, sampling=args.sampling or "random")
    s = res.summary()
    if args.out:
        from bridgeflap.design.io.files import atomic_write_text

        atomic_write_text(args.out, res.to_dataframe().to_csv(index=False))
        s["table"] = str(args.out)
    worst = s["worst_closed_over_open"]
    text = (f"{s['bridge']}: {s['variants']} variants ({s['modes']} modes): "
            f"{100 * s['fraction_stable_to_design_speed']:.1f} % stable to "
            f"{s['design_speed_m_s']:g} m/s, {100 * s['fraction_harmed']:.1f} % harmed, "
            f"worst closed/open {'n/a' if worst is None else f'{worst:.4f}'}, "
            f"{s['unresolved_variants']} unresolved: {s['status']}")
    bound = s["harm_probability_upper_95"]
    text += ("\n" + (f"harm probability <= {100 * bound:.3g} % (one-sided 95 % Clopper-Pearson "
                     f"bound, {s['variants']} independent draws)" if bound is not None
                     else f"harm probability bound: {s['harm_probability_bound']}"))
    if s.get("screen_modes"):
        c = s["screen_check"]
        text += (f"\n{s['method']}: screened on {s['screen_modes']} modes, "
                 f"{s['variants_on_all_modes']} variants on all {s['modes']}; screening change "
                 f"{100 * c['largest_change_rel']:.3f} % (limit {100 * c['limit_rel']:.2f} %): "
                 f"{'passed' if c['passed'] else 'failed, every variant on all modes'}")
    emit(args, s, text)
    return 0 if s["status"] == "no_harm" else 1


def _failures(args) -> int:
    """``--failures``: the single-pair failure table (:func:`bridgeflap.design.assessment.failsafe
    .single_pair_failures`)."""
    import math

    from bridgeflap.design.assessment.failsafe import DEFAULT_STUCK_ANGLE_DEG, single_pair_failures
    from bridgeflap.model.structure.loader import load_bridge

    angle = DEFAULT_STUCK_ANGLE_DEG if args.stuck_angle_deg is None else args.stuck_angle_deg
    if not (math.isfinite(angle) and abs(angle) <= 90.0):
        raise BridgeflapInputError("stuck-angle-deg", f"must be in [-90, 90] deg, got {angle}")
    spec = load_bridge(args.bridge)
    controller = controller_from_args(args, spec)
    res = single_pair_failures(controller, spec, n_modes=args.modes,
                               speed_max_m_s=args.speed_max, stuck_angle_deg=float(angle),
                               workers=args.workers, progress=log)
    s = res.summary()
    s["bridge"] = str(args.bridge)
    if args.out:
        from bridgeflap.design.io.files import atomic_write_text

        atomic_write_text(args.out, res.to_dataframe().to_csv(index=False))
        s["table"] = str(args.out)
    emit(args, s, _failure_text(res, s))
    return 0 if s["status"] == "single_failure_safe" else 1


def _speed(v) -> str:
    return "beyond grid" if v is None else f"{v:.2f}"


def _failure_text(res, s) -> str:
    """The per-pair table and the verdict as text."""
    from bridgeflap.model.results import table_text

    cols = ["pair", "position_m", "edges", "critical_speed_m_s", "critical_mechanism",
            "status", "critical_speed_lower_bound_m_s", "over_intact", "over_open_loop",
            "stuck_twist_max_abs_deg", "stuck_heave_max_abs_m"]
    it, ol, off, w = s["intact"], s["open_loop"], s["controller_off"], s["worst_single_failure"]
    return (f"{s['bridge']}: {s['flap_pairs']} flap pairs ({s['modes']} modes, 0.."
            f"{s['grid_max_m_s']:g} m/s); intact {_speed(it['critical_speed_m_s'])} m/s "
            f"({it['critical_mechanism']}), open loop {_speed(ol['critical_speed_m_s'])} m/s "
            f"({ol['critical_mechanism']}), controller off {_speed(off['critical_speed_m_s'])} "
            f"m/s\n{table_text(res.to_dataframe()[cols])}\n"
            f"stuck at {s['stuck_angle_deg']:g} deg: the same stability as stuck at 0; deck "
            f"twist/heave at {res.rows[0]['stuck_speed_m_s']:g} m/s in the last columns\n"
            f"worst single failure: pair {w['pair']} at {_speed(w['critical_speed_m_s'])} m/s "
            f"({w['critical_mechanism']}); {s['pairs_stable_to_design_speed']}/"
            f"{s['flap_pairs']} stable to {s['design_speed_m_s']:g} m/s: {s['status']}")


def arguments(sp) -> None:
    """The options of ``bridgeflap robustness``."""
    add_common(sp, erection=False)
    sp.add_argument("--controller", default=None,
                    help="controller .toml to judge (its own flap chord and layout)")
    sp.add_argument("--samples", type=int, default=None,
                    help=f"fresh variants drawn over the estimated-input ranges (default "
                         f"{DEFAULT_SAMPLES}, at most {MAX_VARIANTS})")
    sp.add_argument("--seed", type=int, default=None,
                    help=f"seed of the draws (random) or of the Sobol' scramble (default "
                         f"{DEFAULT_SEED})")
    sp.add_argument("--sampling", choices=SAMPLINGS, default=None,
                    help="random (default): independent draws, with the Clopper-Pearson upper "
                         "bound on the harm probability; sobol: even coverage of the ranges, "
                         "no such bound (its points are not independent)")
    sp.add_argument("--modes", type=int, default=30, help="retained modes of every variant")
    sp.add_argument("--speed-max", type=float, default=85.0,
                    help="design speed [m/s]: 'stable to the design speed' is above it")
    sp.add_argument("--workers", type=int, default=default_workers(),
                    help="worker processes (default: min(2, CPUs))")
    sp.add_argument("--scheduler", default=None, metavar="ADDRESS|local",
                    help="run the variants on a Dask cluster: a scheduler address, or 'local' "
                         "for a local one of --workers (default: a local process pool)")
    sp.add_argument("--method", choices=HARM_METHODS, default=None,
                    help="fast (default): critical crossings only, screened on "
                         "--screen-modes; reference: the full sweeps on --modes")
    sp.add_argument("--screen-modes", type=int, default=None, metavar="N",
                    help=f"modes of the fast method's screening (default "
                         f"{DEFAULT_SCREEN_MODES}; 0: none)")
    sp.add_argument("--out", default=None, help="per-variant (or per-pair) table (.csv)")
    sp.add_argument("--failures", action="store_true",
                    help="each single flap pair failed (stuck) and the controller off, on the "
                         "controller's bridge, instead of fresh variants")
    sp.add_argument("--stuck-angle-deg", type=float, default=None,
                    help="angle of a stuck pair [deg] (with --failures; default 5): its static "
                         "deck twist and heave")
