"""``bridgeflap optimise``: design the flap compensator K(s) (the paper, §6), see
bridgeflap.design.control.search.driver."""

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

__all__ = ["arguments", "cmd_optimise"]

#: the default design definition, shipped with the package (a copy lives at
#: runs/humber_flaps.toml; tests/test_runs.py keeps the two identical)
from bridgeflap.design.control.settings import DEFAULT_CARD as DEFAULT_DEFINITION  # noqa: E402


def cmd_optimise(args):
    """Run the design, write the controller TOML and figures to ``--out`` atomically."""
    from bridgeflap.design.control.settings import load_settings, quick_settings

    if args.definition is not None and not Path(args.definition).is_file():
        raise BridgeflapInputError("definition", f"not a file: {args.definition}")
    over = {k: v for k, v in (("objective", getattr(args, "objective", None)),
                              ("margin_min", getattr(args, "margin_min", None)))
            if v is not None}
    from bridgeflap.design.assessment.acceptance import parse_checks

    checks = parse_checks(args.checks)  # a bad --checks stops here, before the design runs
    if args.check_samples is not None and "robustness" not in checks:
        raise BridgeflapInputError("check-samples", "only with the robustness check (--checks "
                                                    "all, or a list naming robustness)")
    from bridgeflap.design.assessment.accept import MAX_SAMPLES

    for name, v, top in (("check-samples", args.check_samples, MAX_SAMPLES),
                         ("workers", args.workers, 1024)):
        if v is not None and not 1 <= v <= top:
            raise BridgeflapInputError(name, f"must be an integer in [1, {top}], got {v}")
    settings = load_settings(args.definition or DEFAULT_DEFINITION, **over)
    if args.quick:
        settings = quick_settings(settings)
    out = Path(args.out)
    check_output_folder("out", out)
    from bridgeflap.model.structure.loader import load_bridge

    load_bridge(settings.bridge)  # bad bridge input stops here, before the design runs
    from bridgeflap.design.io.outputs import check_replaceable, claim_output

    # a foreign non-empty folder, or another command's output, is refused (design.io.outputs)
    out = check_replaceable(out, "out", "optimise")
    with claim_output(out, "out", kind="optimise"):  # one run at a time; crashes recovered
        return _design_and_write(args, settings, out)


def _design_and_write(args, settings, out):
    """Run the design and replace ``out`` by its complete folder (crash-safe swap)."""
    from bridgeflap.design.assessment.accept import design
    from bridgeflap.design.assessment.acceptance import design_closed_loop, parse_checks
    from bridgeflap.design.io.files import atomic_write_text, naming_os_errors, to_jsonable
    from bridgeflap.design.io.outputs import swap_into_place, temporary_sibling, write_marker
    from bridgeflap.model.aeroelastic.controller_file import save_controller

    # the acceptance checks are part of the design's status (design.assessment.accept)
    result = design(settings, progress=log, checks=parse_checks(args.checks) or "none",
                    check_samples=args.check_samples, check_workers=args.workers,
                    quick_checks=args.quick)
    tmp = temporary_sibling(out)
    try:
        tmp.mkdir()
        write_marker(tmp, "optimise")
        payload = result.summary()
        atomic_write_text(tmp / "ipopt_history.json",
                          json.dumps(result.history(), allow_nan=False))
        ctrl_file = out / "controller.toml"
        if result.candidate is not None:
            if result.controller is not None:
                with naming_os_errors(tmp / "controller.toml"):  # e.g. no space left
                    save_controller(result.controller, tmp / "controller.toml")
            import matplotlib

            matplotlib.use("Agg")
            import matplotlib.pyplot as plt

            from bridgeflap.model.results import figure_of
            from bridgeflap.model.stability.sweeps import sweep

            for name, fn in (("bode.png", result.plot_bode), ("margins.png", result.plot_margins)):
                fig = figure_of(fn())
                save_figure(fig, tmp / name)
                plt.close(fig)
            cl = design_closed_loop(result, settings)
            sw = sweep(cl, settings.check_speeds())
            fig = figure_of(sw.plot(title=f"closed loop (design {result.status})"))
            save_figure(fig, tmp / "root_locus.png")
            plt.close(fig)
            if payload.get("response_by_speed"):   # seed Fig. 5 (right), the usable speed
                from bridgeflap.design.assessment.usable_speed import plot_response

                fig = plot_response(payload["response_by_speed"], result.usable_speed(),
                                    title=f"{settings.bridge}: deck response and flap demand "
                                          f"(design {result.status})")
                save_figure(fig, tmp / "response.png")
                plt.close(fig)
        payload["acceptance"] = _acceptance_tables(args, result, tmp)
        payload["controller_file"] = (str(ctrl_file) if result.controller is not None
                                      else None)
        # what --json prints, in the folder too (design.open_run reads it back)
        atomic_write_text(tmp / "summary.json",
                          json.dumps(to_jsonable(payload), allow_nan=False))
        swap_into_place(tmp, out)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    payload["controller_file"] = str(ctrl_file) if result.controller is not None else None
    def g(value, spec):  # strict-JSON numbers: None is "not a number"
        return "nan" if value is None else format(value, spec)

    lines = [f"usable speed {g(payload['usable_speed_m_s'], '.1f')} m/s (limited by "
             f"{payload['usable_speed_limited_by'] or 'not computed: usable_speed check not run'}"
             f") against the open-loop critical speed "
             f"{g(payload['open_loop_critical_speed_m_s'], '.2f')} m/s; linear closed-loop "
             f"critical speed (ideal actuators) "
             f"{g(payload['linear_closed_loop_critical_speed_m_s'], '.2f')} m/s",
             f"status {payload['status']} (acceptance {payload['acceptance']['status']}); "
             f"K(s) coefficients {payload['coefficients']}",
             f"flaps {payload['flap_count']}, max gain {g(payload['max_gain'], '.3g')} "
             f"(limit {settings.gain_limit}), robust margin {g(payload['robust_margin'], '.4g')} "
             f"(worst at {g(payload['robust_margin_worst_speed_m_s'], '.4g')} m/s), "
             f"stable to {payload['closed_loop_stable_to_m_s']} m/s on the "
             f"{payload['design_modes']}-mode design model",
             f"verification ({payload['verification'].get('modes')} modes, "
             f"{payload['verification'].get('step_m_s')} m/s grid): stable everywhere "
             f"{payload['verification'].get('stable_everywhere')}, stable to "
             f"{payload['verification'].get('stable_to_m_s')} m/s",
             ((f"flap layout optimised (placement): {payload['flap_count']} of "
               f"{settings.flap_count} candidate pairs"
               if payload['flap_count'] < settings.flap_count else
               f"flap layout: placement kept every candidate ({payload['flap_count']} of "
               f"{settings.flap_count} pairs; the relaxed weights left none out)")
              if settings.optimise_placement else
              f"minimum flap count (same K) {payload['minimum_flaps']['minimum']}"),
             f"controller written: {payload['controller_file']}"]
    lines.append(f"optimiser gamma_T (Frobenius, sample points) "
                 f"{g(payload['gamma_T_frobenius'], '.4g')} vs dense sigma_max peak "
                 f"{g(payload['dense_T_peak'], '.4g')} (bound holds at the "
                 f"check speeds: {payload['robust_bound_holds']})")
    cs = payload.get("critical_speed")
    if cs:
        lines.append(f"critical-speed search {cs['status']} ({cs['reason']}): design speed "
                     f"{g(cs['design_speed_m_s'], 'g')} m/s (not feasible at "
                     f"{g(cs['not_feasible_speed_m_s'], 'g')} m/s), closed-loop critical speed "
                     f"{g(cs['critical_speed_m_s'], '.2f')} m/s ({cs['critical_mechanism']}), "
                     f"margin {g(cs['robust_margin'], '.4g')} (min {cs['margin_min']}), "
                     f"{cs['inner_solves']} inner solves")
    lines.append(result.table("simple"))
    acc = payload.get("acceptance")
    if acc:
        from bridgeflap.design.assessment.acceptance import acceptance_text

        lines.append(acceptance_text(acc))
    emit(args, payload, "\n".join(lines))
    if acc and acc["status"] in ("harm", "failed", "unresolved"):
        log(f"bridgeflap: design {result.status}: "
            + {"harm": "the controller lowers the critical speed of a bridge variant below its"
                       " open-loop value (JSON acceptance.robustness); controller.toml not "
                       "written",
               "failed": f"{acc.get('reason') or 'the independent closed loop disagrees'} "
                         "(JSON acceptance.independent_check, acceptance.usable_speed); "
                         "controller.toml not written",
               "unresolved": "a fresh variant's crossing is not verified (JSON "
                             "acceptance.robustness); controller.toml not written"}[acc["status"]])
        return 1
    if result.controller is None:
        # the design failed its checks: its candidate is in the JSON (for diagnosis), but no
        # controller.toml is written and the exit status says it is not usable
        best = payload.get("best_achievable") or {}
        log(f"bridgeflap: design {result.status}: no usable controller (controller.toml not "
            "written)" + (f"; best design found: {'; '.join(best['why_not_usable'])} "
                          "(JSON best_achievable)" if best.get("why_not_usable") else ""))
        return 1
    return 0


def _acceptance_tables(args, result, folder) -> dict:
    """The design's acceptance block (:mod:`bridgeflap.design.assessment.accept`) with each check's
    table written as CSV into ``folder``."""
    from bridgeflap.design.io.files import atomic_write_text

    block = dict(result.extras.get("acceptance") or {"checks": [], "status": "not_run"})
    for name, res in (result.extras.get("acceptance_results") or {}).items():
        text = res.csv_text() if name == "actuators" else res.to_dataframe().to_csv(index=False)
        atomic_write_text(folder / f"{name}.csv", text)
        block[name] = {**block[name], "table": str(Path(args.out) / f"{name}.csv")}
    return block


def arguments(sp) -> None:
    """The options of ``bridgeflap optimise``."""
    add_common(sp, bridge=False, erection=False)
    sp.add_argument("definition", nargs="?", default=None,
                    help="design definition .toml (default: the packaged copy of "
                         "runs/humber_flaps.toml)")
    sp.add_argument("--out", default="optimise_out", help="output folder")
    sp.add_argument("--quick", action="store_true",
                    help="reduced problem (one start, a 10 m/s design grid, two cut rounds, "
                         "scenario corners only, 8 fresh variants in the checks): about a "
                         "minute on 2 cores (the full card: about 3 minutes)")
    sp.add_argument("--objective", default=None,
                    help="margin (default: max robust margin, stable to speed_max_m_s) or "
                         "critical_speed (max closed-loop critical speed subject to robust "
                         "margin >= margin_min); overrides the definition's")
    sp.add_argument("--margin-min", dest="margin_min", type=float, default=None,
                    help="robust margin required by the critical_speed objective [-]; "
                         "overrides the definition's")
    sp.add_argument("--checks", default="all", metavar="LIST",
                    help="acceptance checks of the designed controller: all, none, or a comma "
                         "list of independent_check, robustness, failures, actuators, "
                         "usable_speed")
    sp.add_argument("--check-samples", dest="check_samples", type=int, default=None,
                    metavar="N", help="fresh bridge variants of the robustness check "
                                      "(default 1000; 8 with --quick)")
    sp.add_argument("--workers", type=int, default=default_workers(),
                    help="worker processes of the checks (default: min(2, CPUs))")
