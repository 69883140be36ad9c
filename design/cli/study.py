"""CLI commands ``study``, ``doe`` and ``sensitivity`` (listed in
:data:`bridgeflap.design.cli.main.COMMANDS`).

Contracts (``--json``: one JSON object on stdout; progress on stderr; bad input one line and
exit status 2 with nothing written):

* ``bridgeflap study [FILE] [--out DIR] [--quick]`` ->
  ``{"status", "out_dir", "report", "results": {"flutter_speed_m_s", "divergence_speed_m_s", ...}}``
* ``bridgeflap doe FILE [--out DIR] [--workers N] [--scheduler ADDRESS] [--resume]`` ->
  ``{"cases", "succeeded", "failed", "table", ...}``
* ``bridgeflap sensitivity [--bridge B] [--parameters a,b] [--plot FILE]`` ->
  ``{"flutter_speed_m_s", "derivatives": {"<parameter>": {"value_si",
  "d_flutter_speed_m_s_per_unit", "d_flutter_speed_m_s_per_unit_fd", ...}}}``;
  with ``--global morris|sobol`` the SALib study instead.
"""

from __future__ import annotations

from bridgeflap.design.cli.common import (
    add_common,
    check_plot_target,
    default_workers,
    emit,
    log,
    save_plot,
    spec_from_args,
    speed_text,
)
from bridgeflap.design.io.options import parse_range
from bridgeflap.design.studies.analyses import ANALYSES
from bridgeflap.model.errors import BridgeflapInputError
from bridgeflap.model.progress import counted

__all__ = ["cmd_doe", "cmd_sensitivity", "cmd_study", "doe_arguments", "sensitivity_arguments",
           "study_arguments"]


def cmd_study(args):
    from bridgeflap.design.studies.study import load_study, run_study

    config = load_study(args.file, quick=args.quick)
    res = run_study(config, out_dir=args.out, progress=log, workers=args.workers)
    s = res.summary()
    r = s["results"]

    def f(x):
        return "-" if x is None or x != x else f"{x:.2f}"

    lines = [f"study {s['study']}: {s['status']} -> {s['out_dir']}"]
    lines += [f"  {k:16s} {v}" for k, v in s["statuses"].items()]
    lines.append(f"  flutter {f(r['flutter_speed_m_s'])} m/s (paper 65), divergence "
                 f"{f(r['divergence_speed_m_s'])} m/s (paper 74); report {s['report']}")
    emit(args, s, "\n".join(lines))
    design_status = s["statuses"].get("design")
    if design_status is not None and design_status not in ("ok", "converged"):
        # the designed controller is not usable (harm, failed checks, not verified): the
        # study says so in its exit status as well as in its report's first lines
        log(f"bridgeflap: study {s['study']}: design {design_status}: no usable controller "
            f"(report {s['report']})")
        return 1
    return 0


def _local_workers(args) -> int:
    """``--workers`` of a batch (default 1), refused with ``--scheduler``: a scheduler's cluster
    (or ``serial``, in this process) decides how many cases run at once."""
    if args.workers is None:
        return 1
    if args.scheduler is not None:
        raise BridgeflapInputError(
            "workers", f"applies to the local cluster only; with --scheduler {args.scheduler} "
                       "the scheduler's workers run the cases (give one of the two)")
    if args.workers < 1:
        raise BridgeflapInputError("workers", f"must be at least 1, got {args.workers}")
    return int(args.workers)


def cmd_doe(args):
    from bridgeflap.design.studies.experiments import load_doe, run_doe

    workers = _local_workers(args)
    config = load_doe(args.file, quick=args.quick)
    res = run_doe(config, out_dir=args.out, workers=workers, scheduler=args.scheduler,
                  resume=args.resume, progress=not args.json)
    s = res.summary()
    text = (f"doe {s['name']} ({s['analysis']}): {s['cases']} cases, {s['succeeded']} ok, "
            f"{s['failed']} failed, {s['reused']} reused; table {s['table']}")
    emit(args, s, text)


def cmd_sensitivity(args):
    check_plot_target(args)
    if args.global_method:
        return _global(args)
    # design/sensitivity/local.py (H1): one import line
    from bridgeflap.design.sensitivity.local import local_sensitivity

    spec = spec_from_args(args)
    params = (args.parameters if args.parameters
              else ",".join(ANALYSES["sensitivity"].defaults["parameters"]))
    n = len([p for p in params.split(",") if p.strip()])
    res = local_sensitivity(spec, params, speeds=parse_range(args.speeds, "speeds", 0.0),
                            n_modes=args.modes, check=not args.no_check,
                            progress=counted(n, log,
                                             lambda p, k: f"sensitivity: {p} done ({k}/{n})"))
    if args.plot:
        save_plot(res, args.plot)
    text = (f"{spec.name}: flutter {speed_text(res.flutter_speed_m_s, 3)} "
            f"[{res.flutter_status}], divergence {speed_text(res.divergence_speed_m_s, 3)} "
            f"[{res.divergence_status}]\n"
            + res.table())
    emit(args, res.summary(), text)


def _global(args):
    from pathlib import Path

    from bridgeflap.design.studies.screening import DEFAULT_UNCERTAIN_RANGES, global_sensitivity

    ranges = DEFAULT_UNCERTAIN_RANGES
    if args.parameters:
        names = [p.strip() for p in args.parameters.split(",") if p.strip()]
        unknown = [p for p in names if p not in DEFAULT_UNCERTAIN_RANGES]
        if unknown:
            raise BridgeflapInputError("parameters", f"no stated range for {unknown[0]!r} "
                                                     f"(ranges: {', '.join(ranges)})")
        ranges = {p: DEFAULT_UNCERTAIN_RANGES[p] for p in names}
    from bridgeflap.design.io.api_args import check_model_modes

    workers = _local_workers(args)
    # every case runs on --modes: a model with fewer is refused here, not by each case
    check_model_modes(spec_from_args(args), args.modes, "modes")
    out = args.out or str(Path.cwd() / "runs" / "sensitivity" / f"global_{args.global_method}")
    res = global_sensitivity(args.bridge, ranges, method=args.global_method, n=args.samples,
                             out_dir=out, workers=workers, scheduler=args.scheduler,
                             resume=args.resume,
                             case_options={"speeds": args.speeds, "modes": args.modes},
                             progress=not args.json)
    if args.plot:
        save_plot(res, args.plot)
    lines = [f"{res.method}: {res.succeeded}/{res.cases} cases ok ({res.out_dir})"]
    for out_name, b in res.band.items():
        lines.append(f"  {out_name}: 5-50-95 % = {b['p05']:.2f} / {b['p50']:.2f} / "
                     f"{b['p95']:.2f} m/s")
    emit(args, res.summary(), "\n".join(lines))


def study_arguments(sp) -> None:
    """The options of ``bridgeflap study``."""
    sp.add_argument("file", nargs="?", default=None, help="study .toml (default: built-in humber)")
    sp.add_argument("--out", default=None, help="output folder (default runs/<name>/output)")
    sp.add_argument("--quick", action="store_true", help="coarse settings (CI)")
    sp.add_argument("--workers", type=int, default=default_workers(),
                    help="analyses run at once in worker processes (default: min(2, CPU "
                         "count); 1: one after another)")
    add_common(sp, bridge=False, erection=False)


def doe_arguments(sp) -> None:
    """The options of ``bridgeflap doe``."""
    sp.add_argument("file", help="DOE .toml")
    sp.add_argument("--out", default=None, help="output folder (default runs/<name>/output)")
    sp.add_argument("--workers", type=int, default=None,
                    help="processes of the local cluster (default 1; not with --scheduler)")
    sp.add_argument("--scheduler", default=None,
                    help="Dask scheduler address, or 'serial' (default: a local cluster)")
    sp.add_argument("--resume", action="store_true", help="reuse finished cases")
    sp.add_argument("--quick", action="store_true", help="apply the file's [quick] overrides")
    add_common(sp, bridge=False, erection=False)


def sensitivity_arguments(sp) -> None:
    """The options of ``bridgeflap sensitivity`` (grid and modes defaults: the registry's)."""
    defaults = ANALYSES["sensitivity"].defaults
    add_common(sp)
    sp.add_argument("--parameters", default=None, help="comma-separated dotted paths")
    sp.add_argument("--speeds", default=defaults["speeds"], help="start:stop:step [m/s]")
    sp.add_argument("--modes", type=int, default=defaults["modes"])
    sp.add_argument("--no-check", action="store_true", help="skip the finite-difference checks")
    sp.add_argument("--plot", default=None, help="tornado (or global) figure .png/.pdf/.svg")
    sp.add_argument("--global", dest="global_method", choices=("morris", "sobol"), default=None,
                    help="global sensitivity over the estimated inputs' ranges")
    sp.add_argument("--samples", type=int, default=8,
                    help="Morris trajectories or Sobol base sample (power of 2)")
    sp.add_argument("--workers", type=int, default=None,
                    help="processes of --global's local cluster (default 1; not with "
                         "--scheduler)")
    sp.add_argument("--scheduler", default=None)
    sp.add_argument("--resume", action="store_true")
    sp.add_argument("--out", default=None, help="batch folder of --global")
