"""Benchmark: the convergence matrix, one design on every machine
(``python -m bench.reproducible [CARD] [--quick] [--groups last_bit,nearby,doe]``).

Runs ``bridgeflap optimise [CARD] --json`` (the default card, or its ``--quick`` form; the
acceptance checks included unless ``--checks none``) in a subprocess under each setting of
three groups, and compares every run with the first (the machine as found):

* **last bit** -- what differs between machines: numpy's SIMD dispatch as found, with its
  AVX-512 kernels off and with AVX2 off (``NPY_DISABLE_CPU_FEATURES``; a level the CPU lacks is
  skipped and said so); the OpenBLAS kernel as found and ``Sandybridge``; 1 and 2 BLAS threads;
  the model perturbed by 1e-12 relative. Target: converged with acceptance passed, the same
  layout, the closed-loop critical speed within 0.01 m/s, the robust margin within 1e-3.
* **nearby** -- the model perturbed by 1e-9 and 1e-6 relative, ``--draws`` draws each (other
  signs and sizes per input: ``BRIDGEFLAP_PERTURB_REL`` / ``BRIDGEFLAP_PERTURB_SEED``,
  :mod:`bridgeflap.design.control.formulation.problem_model`). Target: converged with acceptance
  passed, the critical speed within 0.05 m/s.
* **doe** -- nearby bridges: a design DOE over the deck's GJ +-10 % and its mass with its
  torsional inertia +-5 % (3 x 3), run through the DOE runner
  (:func:`bridgeflap.design.batch.runner.run_batch`) as a user's design batch runs. Target:
  every case converged with acceptance passed.

It prints the CPU, numpy's SIMD levels, the OpenBLAS kernel and threads of each run, every run's
status, acceptance, layout, critical speed and margin with their differences from the
reference, its wall time, and whether it is within the targets. ``--out DIR`` keeps each run's
JSON there and reuses it on the next call (a long matrix resumes).
"""

from __future__ import annotations

import argparse
import json
import os
import pathlib
import subprocess
import sys
import tempfile
import time

#: the targets of the groups (see the module docstring)
CRITICAL_ATOL_M_S = {"last_bit": 0.01, "nearby": 0.05}
MARGIN_ATOL = {"last_bit": 1e-3}
#: what switches numpy's widest levels off (NPY_DISABLE_CPU_FEATURES); a name the CPU or the
#: numpy build does not know is dropped before use
AVX512_OFF = ("X86_V4", "AVX512_ICL", "AVX512_SPR", "AVX512_SKX", "AVX512F")
AVX2_OFF = ("X86_V3", "AVX2", "FMA3") + AVX512_OFF


def _numpy_features(env=None) -> dict:
    code = ("import json, numpy\n"
            "try:\n    from numpy._core._multiarray_umath import __cpu_features__ as f\n"
            "except ImportError:\n    from numpy.core._multiarray_umath import "
            "__cpu_features__ as f\n"
            "print(json.dumps({k: bool(v) for k, v in f.items()}))")
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
    try:
        return json.loads(out.stdout)
    except json.JSONDecodeError:
        return {}


def _blas(env) -> str:
    code = ("import numpy, threadpoolctl; print(', '.join(f\"{d.get('architecture')} x"
            "{d.get('num_threads')}\" for d in threadpoolctl.threadpool_info() "
            "if d.get('internal_api') == 'openblas'))")
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
    return out.stdout.strip() or "unknown (threadpoolctl not installed)"


def _disable(names, features) -> str | None:
    """The NPY_DISABLE_CPU_FEATURES value for ``names`` this CPU has (None: it has none)."""
    have = [n for n in names if features.get(n)]
    return " ".join(have) or None


def matrix(groups, draws, features) -> list[tuple[str, str, dict]]:
    """``(group, label, extra environment)`` of every run, the reference first."""
    runs = [("last_bit", "as found", {})]
    if "last_bit" in groups:
        for label, names in (("numpy AVX-512 off", AVX512_OFF), ("numpy AVX2 off", AVX2_OFF)):
            off = _disable(names, features)
            if off:
                runs.append(("last_bit", label, {"NPY_DISABLE_CPU_FEATURES": off}))
            else:
                print(f"(skipped: {label}: this CPU has none of {', '.join(names)})",
                      file=sys.stderr)
        runs += [("last_bit", "OpenBLAS Sandybridge", {"OPENBLAS_CORETYPE": "Sandybridge"}),
                 ("last_bit", "2 BLAS threads", {"OPENBLAS_NUM_THREADS": "2"}),
                 ("last_bit", "model 1e-12", {"BRIDGEFLAP_PERTURB_REL": "1e-12"})]
    if "nearby" in groups:
        for rel in ("1e-9", "1e-6"):
            runs += [("nearby", f"model {rel} draw {k}",
                      {"BRIDGEFLAP_PERTURB_REL": rel, "BRIDGEFLAP_PERTURB_SEED": str(k)})
                     for k in range(1, draws + 1)]
    return runs


def _run(card, quick, checks, extra_env, keep: pathlib.Path | None, tag: str) -> dict:
    cached = keep / f"{tag}.json" if keep else None
    if cached is not None and cached.exists():
        return json.loads(cached.read_text())
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1",
           "MPLBACKEND": "Agg", **extra_env}
    with tempfile.TemporaryDirectory() as tmp:
        argv = [sys.executable, "-m", "bridgeflap.design.cli.main", "optimise",
                *([card] if card else []), "--checks", checks, "--json",
                "--out", os.path.join(tmp, "opt"), *(["--quick"] if quick else [])]
        t0 = time.perf_counter()
        proc = subprocess.run(argv, env=env, capture_output=True, text=True)
        wall = time.perf_counter() - t0
    try:
        out = json.loads(proc.stdout) if proc.stdout.strip() else {}
    except json.JSONDecodeError:
        out = {}
    lim = out.get("closed_loop_limits") or {}
    steps = [f"{r.get('step', 'cuts')}:{r.get('status', '')[:20]}"
             for s in out.get("starts") or [] for r in s.get("rounds") or []]
    row = {"env": extra_env, "blas": _blas(env), "exit_code": proc.returncode,
           "status": out.get("status"),
           "acceptance": (out.get("acceptance") or {}).get("status"),
           "flap_positions_m": out.get("flap_positions_m"),
           "critical_speed_m_s": lim.get("critical_speed_m_s"),
           "robust_margin": out.get("robust_margin"), "steps": steps,
           "error": proc.stderr.strip().splitlines()[-1:] if proc.returncode else [],
           "wall_s": round(wall, 1)}
    if cached is not None:
        cached.write_text(json.dumps(row))
    return row


def compare(ref: dict, run: dict, group: str, checks: str) -> dict:
    """The run against the reference and its group's targets."""
    def diff(key):
        a, b = ref.get(key), run.get(key)
        return abs(a - b) if a is not None and b is not None else float("nan")

    du, dm = diff("critical_speed_m_s"), diff("robust_margin")
    ok = run["status"] == "converged" and (checks == "none" or run["acceptance"] == "passed")
    same_layout = ref["flap_positions_m"] == run["flap_positions_m"]
    within = bool(ok and du <= CRITICAL_ATOL_M_S[group]
                  and (group != "last_bit" or (same_layout and dm <= MARGIN_ATOL[group])))
    return {"converged_and_accepted": ok, "same_layout": same_layout,
            "critical_diff_m_s": du, "margin_diff": dm, "within": within}


def doe_rows(card, quick, checks, out: pathlib.Path) -> list[dict]:
    """The nearby-bridges group: a 3 x 3 design DOE through the DOE runner (resumes)."""
    from bridgeflap.design.batch.runner import run_batch

    def pc(x):      # a case id takes letters, digits, '.', '_' and '-': +10 % -> p10pc
        return f"{x:+.0%}".replace("+", "p").replace("-", "m").replace("%", "pc")

    cases = [{"case_id": f"gj{pc(g)}_mass{pc(m)}", "gj_scale": 1.0 + g,
              "mass_scale": 1.0 + m, "card": card or "", "quick": bool(quick),
              "checks": checks}
             for g in (-0.10, 0.0, 0.10) for m in (-0.05, 0.0, 0.05)]
    res = run_batch(design_case, cases, out / "doe", workers=1, scheduler="serial",
                    resume=True, progress=False)
    from bridgeflap.design.batch.table import flat_case_rows

    return flat_case_rows(res.rows)


def design_case(params: dict) -> dict:
    """One DOE case: the card's design on the bridge with GJ and mass-with-inertia scaled."""
    from bridgeflap.design.assessment.accept import design
    from bridgeflap.design.control.settings import load_settings, quick_settings
    from bridgeflap.model.structure.loader import load_bridge

    settings = load_settings(params["card"] or "default")
    if params["quick"]:
        settings = quick_settings(settings)
    d = load_bridge(settings.bridge).deck
    spec = load_bridge(settings.bridge).replace(**{
        "deck.gj_nm2": d.gj_nm2 * params["gj_scale"],
        "deck.mass_kg_per_m": d.mass_kg_per_m * params["mass_scale"],
        "deck.mass_inertia_kgm2_per_m": d.mass_inertia_kgm2_per_m * params["mass_scale"]})
    res = design(settings, bridge=spec, checks="all" if params["checks"] != "none" else "none",
                 quick_checks=bool(params["quick"]))
    s = res.summary()
    return {"design_status": s.get("status"),
            "acceptance": (s.get("acceptance") or {}).get("status"),
            "critical_speed_m_s": (s.get("closed_loop_limits") or {}).get("critical_speed_m_s"),
            "robust_margin": s.get("robust_margin"),
            "usable_speed_m_s": s.get("usable_speed_m_s"),
            "why_not_usable": "; ".join((s.get("best_achievable") or {}).get(
                "why_not_usable", []))}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("card", nargs="?", default=None, help="design card (default: the packaged)")
    p.add_argument("--quick", action="store_true", help="the card's --quick form")
    p.add_argument("--groups", default="last_bit,nearby,doe",
                   help="comma-separated: last_bit, nearby, doe (default: all three)")
    p.add_argument("--draws", type=int, default=5,
                   help="draws per perturbation size in the nearby group (default 5: 10 runs)")
    p.add_argument("--checks", default="all", choices=("all", "none"),
                   help="the acceptance checks of each run (default all)")
    p.add_argument("--out", default=None, help="keep each run's JSON here and resume from it")
    p.add_argument("--json", action="store_true")
    args = p.parse_args(argv)
    groups = {g.strip() for g in args.groups.split(",") if g.strip()}
    bad = groups - {"last_bit", "nearby", "doe"}
    if bad:
        p.error(f"--groups: unknown group(s) {sorted(bad)}")
    keep = pathlib.Path(args.out) if args.out else None
    if keep:
        keep.mkdir(parents=True, exist_ok=True)
    say = (lambda *a, **k: print(*a, file=sys.stderr, **k)) if args.json else print
    features = _numpy_features()
    cpu = next((ln.split(":", 1)[1].strip() for ln in
                pathlib.Path("/proc/cpuinfo").read_text().splitlines()
                if ln.startswith("model name")), "unknown") \
        if pathlib.Path("/proc/cpuinfo").exists() else "unknown"
    simd = [k for k in ("X86_V3", "X86_V4", "AVX512_ICL", "AVX512_SPR", "AVX2", "AVX512F")
            if features.get(k)]
    say(f"CPU: {cpu}; {os.cpu_count()} CPUs; numpy SIMD levels found: {', '.join(simd)}; "
          f"card: {args.card or 'default'}{' --quick' if args.quick else ''}; checks "
          f"{args.checks}", flush=True)
    rows = []
    plan = matrix(groups, args.draws, features)
    for i, (group, label, env) in enumerate(plan):
        tag = f"{'q_' if args.quick else ''}{i:02d}_" + label.replace(" ", "_")
        r = _run(args.card, args.quick, args.checks, env, keep, tag)
        r = {"group": group, "label": label, **r}
        r.update(compare(rows[0] if rows else r, r, group, args.checks))
        rows.append(r)
        say(f"  [{group}] {label:24s} BLAS {r['blas']:18s} {r['status']}, acceptance "
              f"{r['acceptance']}, {len(r['flap_positions_m'] or [])} flaps, critical "
              f"{r['critical_speed_m_s']} m/s (diff {r['critical_diff_m_s']:.1e}), margin "
              f"{r['robust_margin']} (diff {r['margin_diff']:.1e}), {r['wall_s']} s: "
              f"{'within' if r['within'] else 'OUTSIDE'}  [{' '.join(r['steps'])}]",
              flush=True)
    doe = []
    if "doe" in groups:
        with tempfile.TemporaryDirectory() as tmp:
            doe = doe_rows(args.card, args.quick, args.checks, keep or pathlib.Path(tmp))
        for r in doe:
            ok = (r.get("design_status") == "converged"
                  and (args.checks == "none" or r.get("acceptance") == "passed"))
            r["within"] = ok
            say(f"  [doe] {r.get('case_id'):24s} {r.get('status')}: design "
                  f"{r.get('design_status')}, acceptance {r.get('acceptance')}, critical "
                  f"{r.get('critical_speed_m_s')} m/s: {'within' if ok else 'OUTSIDE'}",
                  flush=True)
    out = {"cpu": cpu, "cpu_count": os.cpu_count(), "numpy_simd": simd,
           "targets": {"critical_m_s": CRITICAL_ATOL_M_S, "margin": MARGIN_ATOL},
           "runs": rows, "doe": doe,
           "all_within": all(r["within"] for r in rows + doe)}
    if args.json:
        print(json.dumps(out, default=str))
    say(f"all within the targets: {out['all_within']} ({sum(r['within'] for r in rows + doe)}"
          f" of {len(rows + doe)})")
    return 0 if out["all_within"] else 1


if __name__ == "__main__":
    raise SystemExit(main())
