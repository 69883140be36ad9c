"""Benchmark of the stability sweep: modal vs full-order state space vs exact p-k.

Run ``python -m bench.stability`` (tables) or ``python -m bench.stability --json`` (one JSON
object). Set ``OPENBLAS_NUM_THREADS=1`` on a loaded machine (multithreaded OpenBLAS on small
dense ``eig`` calls can be slower by one to two orders of magnitude); the header reports it.

One Humber wind-speed sweep (default ``0:85:0.5``, 171 speeds) with the same retained modes
(default 16 vertical + torsional) by three methods:

* ``modal``: :func:`bridgeflap.model.aeroelastic.statespace.build` with ``order="modal"`` (4 lag
  states per mode),
  :func:`bridgeflap.model.stability.sweeps.sweep` (dense ``eig`` per speed, branch tracking, Brent
  refinement);
* ``full``: the same with ``order="full"`` (4 lag states per aerodynamic strip), the reference
  assembly that the modal lag reduction must reproduce (docs/methods.md#state-space);
* ``p-k``: :func:`bridgeflap.model.stability.sweeps.pk_sweep` with the exact Theodorsen function on
  the same modes (``states`` is the size ``2 n`` of the eigenproblem solved per p-k iteration; the
  ``U = 0`` point is skipped, where ``k`` is undefined).

Columns: build and sweep wall time (best of ``--repeat``, outside tracemalloc), peak traced
memory of the sweep (a separate run under :mod:`tracemalloc`: numpy array data are traced;
LAPACK workspaces allocated in C inside ``numpy.linalg`` are not), flutter speed, time ratio
and flutter-speed difference against ``modal``.

``--sweeps`` prints instead the dense against the fast sweep
(:mod:`bridgeflap.model.stability.hopf`) on the stated set of :func:`bench.sweep_cases.cases`
(Humber open and closed loop, IABSE 1.1a, 1.1c, 2a, 2a:bb3, Great Belt with its default and its bb3
derivatives): eigen-solution counts, times (best of ``--repeat``), their ratios and the agreement;
``--sampled N`` adds ``N`` bridges sampled from Humber's estimated-input ranges and erection stages,
counted as agreements and disagreements (each disagreement listed).

The modal truncation study repeats the modal sweep with 8 ... 30 retained modes (one
eigen-solution of the structure is shared; its cost is reported once in the header).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import time
import tracemalloc
from pathlib import Path

import numpy as np
import scipy

from bridgeflap.design.io.files import to_jsonable
from bridgeflap.design.io.options import parse_range
from bridgeflap.design.studies.analyses import DEFAULT_SPEEDS
from bridgeflap.model.aero.rfa import get_rfa
from bridgeflap.model.analysis import bridge_system, modal_model
from bridgeflap.model.stability import sweeps as stability
from bridgeflap.model.structure.loader import load_bridge

TRUNCATION = (8, 12, 16, 20, 24, 30)


def _timed(fn, repeat: int):
    """(result, best wall time [s]) of ``fn()`` over ``repeat`` runs."""
    best, out = float("inf"), None
    for _ in range(max(1, repeat)):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return out, best


def _peak_mb(fn) -> float:
    """Peak memory [MB] traced by :mod:`tracemalloc` while ``fn()`` runs."""
    tracemalloc.start()
    tracemalloc.reset_peak()
    try:
        fn()
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    return peak / 1e6


def _method_row(method, system, speeds, repeat, memory, build_s):
    if method == "p-k":
        def run():
            return stability.pk_sweep(system, speeds)
        states = 2 * system.basis.n
    else:
        def run():
            return stability.sweep(system, speeds)
        states = system.n_states
    res, t = _timed(run, repeat)
    mem = _peak_mb(run) if memory else float("nan")
    row = {"method": method, "states": int(states), "build_s": build_s, "sweep_s": t,
           "peak_memory_mb": mem, "flutter_speed_m_s": res.flutter.speed,
           "flutter_frequency_hz": res.flutter.frequency_hz, "flutter_status": res.flutter.status}
    if method != "p-k":
        row.update(divergence_speed_m_s=res.divergence.speed,
                   divergence_status=res.divergence.status)
    else:
        row.update(divergence_speed_m_s=float("nan"), divergence_status="not computed by p-k")
    return row


def run(bridge: str = "humber", speeds: str = DEFAULT_SPEEDS, n_modes: int = 16,
        truncation=TRUNCATION, repeat: int = 1, memory: bool = True) -> dict:
    """Benchmark result as a JSON-ready dict (config, environment, methods, truncation)."""
    spec = load_bridge(bridge)
    grid = parse_range(speeds, "speeds", 0.0)
    get_rfa("rfa4")  # the 4-lag fit is computed once per process: keep it out of the timings
    t0 = time.perf_counter()
    modal = modal_model(spec)
    modal_s = time.perf_counter() - t0

    rows = []
    for method, order in (("modal", "modal"), ("full", "full"), ("p-k", "modal")):
        (_, system), build_s = _timed(
            lambda order=order: bridge_system(spec, n_modes, order=order, modal=modal), repeat)
        rows.append(_method_row(method, system, grid, repeat, memory, build_s))
    ref = rows[0]
    for r in rows:
        r["time_ratio_vs_modal"] = r["sweep_s"] / ref["sweep_s"]
        r["flutter_diff_vs_modal_m_s"] = r["flutter_speed_m_s"] - ref["flutter_speed_m_s"]
        r["flutter_rel_diff_vs_modal"] = r["flutter_diff_vs_modal_m_s"] / ref["flutter_speed_m_s"]

    trunc = []
    for n in truncation:
        def one(n=n):
            _, system = bridge_system(spec, n, modal=modal)
            return system, stability.sweep(system, grid)

        (system, sw), t = _timed(one, repeat)
        trunc.append({"modes": int(n), "states": int(system.n_states), "time_s": t,
                      "flutter_speed_m_s": sw.flutter.speed,
                      "flutter_frequency_hz": sw.flutter.frequency_hz,
                      "flutter_status": sw.flutter.status,
                      "divergence_speed_m_s": sw.divergence.speed,
                      "divergence_status": sw.divergence.status,
                      "critical_branch": sw.critical_branch,
                      "retained": list(system.basis.labels)})
    return {
        "config": {"bridge": bridge, "speeds": speeds, "n_speeds": int(grid.size),
                   "modes": n_modes, "truncation": [int(n) for n in truncation],
                   "repeat": repeat, "half_chord_m": spec.deck.half_chord_m,
                   "element_length_m": spec.mesh.element_length_m,
                   "n_strips": len(modal.structure.strip_x),
                   "modal_solution_s": modal_s},
        "environment": {"python": platform.python_version(), "numpy": np.__version__,
                        "scipy": scipy.__version__, "git_commit": _git_commit(),
                        "OPENBLAS_NUM_THREADS": os.environ.get("OPENBLAS_NUM_THREADS"),
                        "OMP_NUM_THREADS": os.environ.get("OMP_NUM_THREADS"),
                        "cpu_count": os.cpu_count()},
        "methods": rows,
        "truncation": trunc,
    }


def _git_commit() -> str | None:
    try:
        out = subprocess.run(["git", "rev-parse", "HEAD"], capture_output=True, text=True,
                             cwd=Path(__file__).parent, timeout=10, check=True)
        return out.stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return None


def format_table(result: dict) -> str:
    """Plain-text tables of :func:`run`'s result."""
    c, env = result["config"], result["environment"]
    lines = [
        f"bridgeflap bench.stability: {c['bridge']}, {c['n_speeds']} speeds ({c['speeds']} m/s), "
        f"{c['modes']} modes, b = {c['half_chord_m']} m, {c['n_strips']} strips; numpy "
        f"{env['numpy']}, scipy {env['scipy']}, OPENBLAS_NUM_THREADS="
        f"{env['OPENBLAS_NUM_THREADS']}, cpus={env['cpu_count']}",
        f"structural eigen-solution (shared): {c['modal_solution_s']:.2f} s; times are best of "
        f"{c['repeat']}; memory = tracemalloc peak of the sweep",
        f"{'method':<6} {'states':>6} {'build [s]':>9} {'sweep [s]':>9} {'peak MB':>8} "
        f"{'U_F [m/s]':>10} {'t/modal':>8} {'dU_F [m/s]':>11} {'dU_F/U_F':>9}  status",
    ]
    for r in result["methods"]:
        lines.append(
            f"{r['method']:<6} {r['states']:6d} {r['build_s']:9.3f} {r['sweep_s']:9.3f} "
            f"{r['peak_memory_mb']:8.2f} {r['flutter_speed_m_s']:10.4f} "
            f"{r['time_ratio_vs_modal']:8.2f} {r['flutter_diff_vs_modal_m_s']:+11.2e} "
            f"{r['flutter_rel_diff_vs_modal']:+9.2e}  {r['flutter_status']}")
    lines += ["", "modal truncation (vertical + torsional modes, lowest first)",
              f"{'modes':>5} {'states':>6} {'time [s]':>8} {'U_F [m/s]':>10} {'f_F [Hz]':>8} "
              f"{'U_D [m/s]':>10} {'branch':>6}  statuses"]
    for r in result["truncation"]:
        lines.append(
            f"{r['modes']:5d} {r['states']:6d} {r['time_s']:8.3f} {r['flutter_speed_m_s']:10.4f} "
            f"{r['flutter_frequency_hz']:8.4f} {r['divergence_speed_m_s']:10.4f} "
            f"{r['critical_branch']:>6}  {r['flutter_status']}/{r['divergence_status']}")
    return "\n".join(lines)


def run_sweeps(n_modes: int = 30, repeat: int = 5, sampled: int = 0) -> dict:
    """Dense against fast sweep on the stated set and ``sampled`` sampled bridges."""
    from bench import sweep_cases as sc

    rows = [sc.compare(*case, repeat=repeat) for case in sc.cases(n_modes)]
    samples = []
    for k, params in enumerate(sc.sampled_params(sampled)):
        r = sc.compare(*sc.sampled_case(params, n_modes), repeat=1)
        r.update(case=f"sample {k}", params=params)
        samples.append(r)
    env = {"cpu_count": os.cpu_count(),
           "OPENBLAS_NUM_THREADS": os.environ.get("OPENBLAS_NUM_THREADS"),
           "git_commit": _git_commit(), "numpy": np.__version__, "scipy": scipy.__version__}
    tot = {m: sum(r[f"{m}_eigen_solutions"] for r in samples) for m in ("dense", "fast")}
    return {"environment": env, "modes": n_modes, "repeat": repeat, "cases": rows,
            "sampled": {"n": len(samples), "agree": sum(r["agree"] for r in samples),
                        "disagree": [r for r in samples if not r["agree"]],
                        "fallbacks": sum(r["fast_method"] == "dense" for r in samples),
                        "fallback_reasons": sorted(r["fallback_reason"] for r in samples
                                                   if r["fallback_reason"]),
                        "dense_eigen_solutions": tot["dense"],
                        "fast_eigen_solutions": tot["fast"],
                        "dense_s": sum(r["dense_s"] for r in samples),
                        "fast_s": sum(r["fast_s"] for r in samples)}}


def format_sweeps(result: dict) -> str:
    """Plain-text table of :func:`run_sweeps`."""
    env = result["environment"]
    lines = [f"dense vs fast stability sweep ({result['modes']} modes; times best of "
             f"{result['repeat']}); cpus={env['cpu_count']}, OPENBLAS_NUM_THREADS="
             f"{env['OPENBLAS_NUM_THREADS']}",
             f"{'case':<20} {'states':>6} {'speeds':>6} {'eig dense':>9} {'eig fast':>8} "
             f"{'ratio':>6} {'dense [s]':>9} {'fast [s]':>8} {'ratio':>6} {'max rel dU':>10}"
             f"  agree  fast path"]
    for r in result["cases"]:
        path = r["fast_method"] + (f" ({r['fallback_reason']})" if r["fallback_reason"] else "")
        lines.append(
            f"{r['case']:<20} {r['states']:6d} {r['n_speeds']:6d} "
            f"{r['dense_eigen_solutions']:9d} {r['fast_eigen_solutions']:8d} "
            f"{r['eigen_solution_ratio']:6.1f} {r['dense_s']:9.3f} {r['fast_s']:8.3f} "
            f"{r['time_ratio']:6.1f} {r['max_rel_speed_diff']:10.2e}  "
            f"{'yes' if r['agree'] else 'NO '}    {path}")
        if r["differences"]:
            lines.append(f"{'':<20} differences: {', '.join(r['differences'])}")
    s = result["sampled"]
    if s["n"]:
        lines.append(
            f"sampled bridges: {s['agree']} of {s['n']} agree, {len(s['disagree'])} disagree; "
            f"{s['fallbacks']} fell back to dense; eigen-solutions {s['dense_eigen_solutions']} "
            f"dense / {s['fast_eigen_solutions']} fast "
            f"({s['dense_eigen_solutions'] / max(s['fast_eigen_solutions'], 1):.1f}x), "
            f"time {s['dense_s']:.1f} / {s['fast_s']:.1f} s")
        for why in sorted(set(s["fallback_reasons"])):
            lines.append(f"  fallback x{s['fallback_reasons'].count(why)}: {why}")
        for r in s["disagree"]:
            lines.append(f"  {r['case']}: {', '.join(r['differences'])}; {r['params']}")
    return "\n".join(lines)


def main(argv=None) -> int:
    """Command-line entry point."""
    p = argparse.ArgumentParser(prog="python -m bench.stability",
                                description=__doc__.split("\n")[0])
    p.add_argument("--bridge", default="humber", help="built-in name or path to a .toml file")
    p.add_argument("--speeds", default=DEFAULT_SPEEDS, help="start:stop:step [m/s]")
    p.add_argument("--modes", type=int, default=16, help="retained modes for the comparison")
    p.add_argument("--truncation", type=int, nargs="+", default=list(TRUNCATION),
                   help="mode counts of the truncation study")
    p.add_argument("--repeat", type=int, default=1, help="timing repeats (best is kept)")
    p.add_argument("--no-memory", action="store_true", help="skip the tracemalloc runs")
    p.add_argument("--json", action="store_true", help="print one JSON object instead")
    p.add_argument("--sweeps", action="store_true",
                   help="dense vs fast sweep on the stated cases instead (modes: --modes, "
                        "default 30 here)")
    p.add_argument("--sampled", type=int, default=0,
                   help="with --sweeps: also N sampled bridges and erection stages")
    a = p.parse_args(argv)
    if a.sweeps:
        modes = 30 if a.modes == 16 and "--modes" not in (argv or sys.argv) else a.modes
        result = run_sweeps(modes, a.repeat, a.sampled)
        print(json.dumps(to_jsonable(result), allow_nan=False) if a.json
              else format_sweeps(result))
        return 0
    result = run(a.bridge, a.speeds, a.modes, a.truncation, a.repeat, not a.no_memory)
    if a.json:
        print(json.dumps(to_jsonable(result), allow_nan=False))
    else:
        print(format_table(result))
    return 0


if __name__ == "__main__":
    sys.exit(main())
