"""Benchmark: the do-no-harm check (``python -m bench.robustness [--samples 200]
[--reference-samples 20] [--workers 2] [--repeats 1] [--controller FILE] [--json]``).

Times :func:`bridgeflap.design.assessment.harm.do_no_harm` on Humber (30 modes, 0-127.5 m/s at 0.5
m/s, Sobol' seed 11) with ``method="fast"`` (screened on 16 modes) at ``--samples`` and with the
reference ``method="reference"`` at ``--reference-samples`` (the full reference at 200 samples takes
~10 min of two shared cores; its wall time per variant is scaled to ``--samples``, which the
table says). Both methods also run on the reference's sample count, where their summaries are
compared: verdicts equal, the worst closed/open ratio and the lowest closed-loop speed within
2e-3 m/s (tests/test_harm_fast.py). Printed: a table (samples, wall and CPU time, wall per
variant, ratio to the reference, status, fractions, worst ratio, lowest and highest closed-loop
critical speed, rows on all modes), the CPU count, the BLAS threads and the load (``uptime``)
before and after. The machine is shared: ``--repeats N`` reports the best of N fast runs.

The controller (default): the default design's K(s) and 18 flap pairs, 3 m chord, LE + TE
(as tests/test_harm.py).
"""

from __future__ import annotations

import argparse
import json
import os
import time

from bench.design import _blas_threads, _cpu_s, _uptime

#: the do-no-harm result of the reference at 200 variants (README, "Do no harm")
README_200 = {"status": "no_harm", "worst_closed_over_open": 1.144,
              "fraction_stable_to_design_speed": 0.730,
              "closed_loop_critical_speed_range_m_s": (78.91, 96.86)}


def _controller(path=None):
    from bridgeflap.model.aeroelastic.control import Compensator, Controller

    if path:
        from bridgeflap.model.aeroelastic.controller_file import load_controller

        return load_controller(path)
    k = Compensator(-1.0520215923792988, 0.724204088492299, -4.9906722869878095,
                    0.24572479364985136, 0.19628837741003988)
    return Controller(k, tuple(56.4 * i for i in range(-12, 13) if abs(i) >= 4), 56.4,
                      flap_chord_m=3.0)


def _one(controller, samples, method, workers) -> tuple[dict, float, float, object]:
    from bridgeflap.design.assessment.harm import do_no_harm

    cpu0, t0 = _cpu_s(), time.perf_counter()
    res = do_no_harm(controller, "humber", count=samples, workers=workers, method=method)
    return res.summary(), time.perf_counter() - t0, _cpu_s() - cpu0, res


def _row(method, samples, s, wall, cpu, res, ref_per_variant, scaled=False) -> dict:
    speeds = [r["closed_loop_critical_speed_m_s"] for r in res.rows
              if r["closed_loop_critical_speed_m_s"] is not None]
    return {"method": method, "samples": samples, "wall_s": round(wall, 1),
            "cpu_s": round(cpu, 1), "wall_per_variant_s": round(wall / samples, 3),
            "ratio_to_reference": (round(wall / (ref_per_variant * samples), 3)
                                   if ref_per_variant else None),
            "scaled": scaled, "status": s["status"],
            "fraction_stable": s["fraction_stable_to_design_speed"],
            "fraction_harmed": s["fraction_harmed"],
            "worst_closed_over_open": round(s["worst_closed_over_open"], 5)
            if s["worst_closed_over_open"] is not None else None,
            "closed_loop_min_m_s": round(min(speeds), 3) if speeds else None,
            "closed_loop_max_m_s": round(max(speeds), 3) if speeds else None,
            "closed_loop_mechanisms": sorted({r["closed_loop_mechanism"] for r in res.rows}),
            "variants_on_all_modes": s["variants_on_all_modes"],
            "screen_check_passed": s.get("screen_check", {}).get("passed")}


def _agree(a: dict, b: dict, ra, rb) -> dict:
    """Fast (``a``) against reference (``b``) summaries on the same variants."""
    same = all(a[k] == b[k] for k in ("status", "fraction_stable_to_design_speed",
                                      "fraction_harmed", "unresolved_variants",
                                      "worst_variant"))
    d_ratio = abs(a["worst_closed_over_open"] - b["worst_closed_over_open"])
    d_min = abs(a["worst_closed_loop_critical_speed_m_s"]
                - b["worst_closed_loop_critical_speed_m_s"])
    verdicts = all(x[k] == y[k] for x, y in zip(ra.rows, rb.rows, strict=True)
                   for k in ("stable_to_design_speed", "harmed", "resolved"))
    return {"verdict_fields_equal": same, "row_verdicts_equal": verdicts,
            "worst_ratio_difference": d_ratio, "lowest_closed_loop_difference_m_s": d_min,
            "agree": bool(same and verdicts and d_min <= 2e-3 and d_ratio <= 2e-3 / 50)}


def run(samples=200, reference_samples=20, workers=2, repeats=1, controller=None) -> dict:
    """The table's rows and the agreement (module docstring)."""
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    c = _controller(controller)
    up0 = _uptime()
    s_ref, w_ref, c_ref, r_ref = _one(c, reference_samples, "reference", workers)
    per = w_ref / reference_samples
    s_fs, w_fs, c_fs, r_fs = _one(c, reference_samples, "fast", workers)
    best = None
    for _ in range(max(1, int(repeats))):
        got = _one(c, samples, "fast", workers)
        if best is None or got[1] < best[1]:
            best = got
    s_f, w_f, c_f, r_f = best
    rows = [_row("reference", reference_samples, s_ref, w_ref, c_ref, r_ref, per),
            _row("reference (scaled)", samples, s_ref, per * samples,
                 c_ref / reference_samples * samples, r_ref, per, scaled=True),
            _row("fast", reference_samples, s_fs, w_fs, c_fs, r_fs, per),
            _row("fast", samples, s_f, w_f, c_f, r_f, per)]
    rows[1].update({k: None for k in ("status", "fraction_stable", "fraction_harmed",
                                      "worst_closed_over_open", "closed_loop_min_m_s",
                                      "closed_loop_max_m_s", "variants_on_all_modes")})
    return {"rows": rows, "agreement_at_reference_samples": _agree(s_fs, s_ref, r_fs, r_ref),
            "readme_reference_200": README_200, "target_wall_time_s": 60.0,
            "cpu_count": os.cpu_count(), "blas_threads": _blas_threads(), "workers": workers,
            "repeats": repeats, "uptime_before": up0, "uptime_after": _uptime()}


def main(argv=None) -> int:
    """Command-line entry."""
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--samples", type=int, default=200)
    p.add_argument("--reference-samples", type=int, default=20)
    p.add_argument("--workers", type=int, default=2)
    p.add_argument("--repeats", type=int, default=1, help="fast runs; the best is reported")
    p.add_argument("--controller", default=None, help="controller .toml (default: the "
                                                      "default design's K and layout)")
    p.add_argument("--json", action="store_true")
    args = p.parse_args(argv)
    out = run(args.samples, args.reference_samples, args.workers, args.repeats,
              args.controller)
    if args.json:
        print(json.dumps({"robustness": out}))
        return 0
    keys = ["method", "samples", "wall_s", "cpu_s", "wall_per_variant_s",
            "ratio_to_reference", "status", "fraction_stable", "worst_closed_over_open",
            "closed_loop_min_m_s", "closed_loop_max_m_s", "variants_on_all_modes",
            "screen_check_passed"]
    print(" | ".join(keys))
    for r in out["rows"]:
        print(" | ".join("-" if r[k] is None else str(r[k]) for k in keys))
    print(f"reference (scaled): its wall per variant at {args.reference_samples} variants "
          f"times {args.samples}")
    print(f"agreement on {args.reference_samples} variants: "
          f"{out['agreement_at_reference_samples']}")
    print(f"README, reference at 200 variants: {README_200}")
    print(f"{out['cpu_count']} CPUs, BLAS threads {out['blas_threads']}, {args.workers} "
          f"workers, best of {args.repeats} fast run(s); target {out['target_wall_time_s']} s")
    print(f"before: {out['uptime_before']}\nafter:  {out['uptime_after']}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
