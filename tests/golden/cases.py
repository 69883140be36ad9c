"""Golden-number cases: fixed CLI commands whose ``--json`` output pins today's numbers.

Recorded before the "one physics path" redesign by
``cd tests && python -m golden.record`` and compared after every change by
``tests/test_golden.py`` to 1e-9 relative. A number that changes on purpose is a named fix:
re-record and say so in the commit.

Each case is ``(name, argv, slow)``; ``{out}`` in an argument is replaced by a temporary folder.
"""

from __future__ import annotations

import contextlib
import io
import json
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]

_SECTION = ["--mass", "7660", "--inertia", "375000", "--f-heave", "0.117", "--f-torsion",
            "0.311", "--half-chord", "11"]

CASES = [
    ("modes", ["modes"], False),
    ("flutter_modal", ["flutter"], False),
    ("flutter_full", ["flutter", "--order", "full"], False),
    ("erection", ["erection"], False),
    ("frequency_ratio", ["frequency-ratio"], False),
    ("section_exact", ["section", *_SECTION, "--aero", "exact"], False),
    ("section_rfa4", ["section", *_SECTION, "--aero", "rfa4"], False),
    ("section_jones", ["section", *_SECTION, "--aero", "jones"], False),
    ("buffeting", ["buffeting"], False),
    ("flutter_iabse_2a", ["flutter", "--bridge", "iabse-2a"], False),
    ("flutter_great_belt", ["flutter", "--bridge", "great-belt", "--speeds", "0:150:0.5"], False),
    ("flutter_iabse_1_1c", ["flutter", "--bridge", "iabse-1.1c"], False),
    ("flutter_iabse_2a_bb3", ["flutter", "--bridge", "iabse-2a:bb3"], False),
    ("state_space", ["state-space", "--speed", "40", "--out", "{out}/ss.npz"], False),
    ("sensitivity", ["sensitivity"], True),
    ("doe_4", ["doe", str(ROOT / "runs" / "doe_gj_sag" / "doe.toml"), "--quick",
               "--scheduler", "serial", "--out", "{out}/doe"], False),
    ("optimise_quick", ["optimise", "--quick", "--out", "{out}/opt"], True),
    # the built-in b = 14.25 m Humber, evenly spaced 25 pairs, the older quick settings: failed
    # its checks (exit 1) before the model updating; converges since (86.39 m/s)
    ("optimise_quick_b1425", ["optimise", str(HERE / "humber_b1425_flaps.toml"), "--quick",
                              "--out", "{out}/opt"], True),
]

#: keys whose values depend on the machine, the clock or the folder, not on the physics
VOLATILE = {"out", "table", "out_dir", "elapsed_s", "time_s", "seconds", "wall_time_s",
            "figures", "files", "manifest", "report", "path", "duration_s", "controller_file",
            "eig_time_per_speed_s", "time_per_start_s", "case_hash"}


def _extra(name: str, out: Path) -> dict:
    """Numbers written to files rather than printed (state-space arrays, DOE cases)."""
    if name == "state_space":
        with np.load(out / "ss.npz", allow_pickle=False) as z:
            return {k: float(np.linalg.norm(z[k])) for k in ("A", "B", "C") if k in z.files}
    if name == "doe_4":
        cases = sorted((out / "doe" / "cases").glob("*.json"))
        return {p.stem: json.loads(p.read_text()) for p in cases}
    return {}


def run_case(name: str, argv: list[str], out: Path) -> dict:
    """Run one CLI command in-process and return its JSON plus the file numbers."""
    from bridgeflap.design.cli.main import main

    argv = [a.replace("{out}", str(out)) for a in argv] + ["--json"]
    buf, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(buf), contextlib.redirect_stderr(err):
        rc = main(argv)
    if rc not in (0, 1) or not buf.getvalue().strip():
        # 1 is a result that is not usable (a failed design), still reported as JSON
        raise RuntimeError(f"{name}: exit {rc}: {err.getvalue()[-2000:]}")
    return {"exit_code": rc, "stdout": json.loads(buf.getvalue()),
            "written": _extra(name, out)}


def strip_volatile(obj):
    """Drop machine/clock/path dependent keys, recursively."""
    if isinstance(obj, dict):
        return {k: strip_volatile(v) for k, v in obj.items()
                if k not in VOLATILE and not k.endswith("_time_s") and k != "elapsed_s"}
    if isinstance(obj, list):
        return [strip_volatile(v) for v in obj]
    return obj


#: Ipopt statuses of a converged solve; any other round is an iterate cut off by a limit
CONVERGED_IPOPT = {"Solve_Succeeded", "Solved_To_Acceptable_Level"}
#: tolerance for the numbers of an unconverged (iteration-capped) Ipopt round: its iterate at
#: the cap amplifies round-off of the problem data (1e-15) by the ill-conditioning of an
#: unfinished solve; measured 5e-9 relative after 20 capped iterations, 1e-6 leaves margin and
#: still fails on any change of the problem itself (those move the iterate by > 1e-4)
RTOL_UNCONVERGED = 1e-6


def compare(a, b, rtol: float, path: str = "", atol: float = 1e-12) -> list[str]:
    """Differences between two JSON trees: numbers to ``rtol`` relative (plus ``atol``), the
    rest exactly.

    A dict with an Ipopt ``status`` that is not a converged one (a design round stopped at its
    iteration cap) is compared to :data:`RTOL_UNCONVERGED`; its status must still match.
    """
    out: list[str] = []
    if isinstance(a, dict) and isinstance(b, dict):
        status = a.get("status")
        if (isinstance(status, str) and status[:1].isupper() and "_" in status
                and status not in CONVERGED_IPOPT
                and status == b.get("status")):
            rtol = max(rtol, RTOL_UNCONVERGED)
        for k in sorted(set(a) | set(b)):
            if k not in a or k not in b:
                out.append(f"{path}/{k}: key only in {'new' if k in b else 'golden'}")
            else:
                out += compare(a[k], b[k], rtol, f"{path}/{k}", atol)
    elif isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            out.append(f"{path}: length {len(a)} != {len(b)}")
        else:
            for i, (x, y) in enumerate(zip(a, b, strict=True)):
                out += compare(x, y, rtol, f"{path}[{i}]", atol)
    elif (isinstance(a, int | float) and isinstance(b, int | float)
          and not isinstance(a, bool) and not isinstance(b, bool)):
        # absolute floor (default 1e-12): residual-like fields (Re lambda at a refined
        # crossing) are round-off of order 1e-14 and carry no physics
        if abs(a - b) > rtol * max(abs(a), abs(b)) + atol:
            out.append(f"{path}: {a!r} != {b!r}")
    elif a != b:
        out.append(f"{path}: {a!r} != {b!r}")
    return out


#: Per-case ``(rtol, atol)`` where the default (``test_golden.RTOL``, 1e-12) does not apply.
#: ``sensitivity``: its finite-difference derivatives divide the round-off of two solved
#: speeds (~1e-10 relative) by the relative step, so they reproduce to ~1e-6 relative across
#: library releases (measured 1.5e-6, numpy 2.4.6 / scipy 1.17.1 against the recording), and a
#: derivative that is physically zero (divergence against damping) is that round-off itself
#: (1e-9 absolute measured); on an AMD EPYC (OpenBLAS SkylakeX kernel) that zero derivative
#: is -9.9e-9 against the recorded 5.7e-9 (1.6e-8 apart), so the floor is 5e-8; 1e-5 and 5e-8
#: still fail on any change of the model (a 1 % change of an input moves these derivatives by
#: > 1e-3 relative).
CASE_TOL = {"sensitivity": (1e-5, 5e-8)}

#: Design cases (Ipopt): compared on :func:`design_summary` only, on what a user reads. What
#: must reproduce: the exit code, status, acceptance verdict, usability, settings, the flap
#: layout, the open-loop limits (no optimiser involved: to the default tolerance) and, for a
#: usable design, the robust margin to DESIGN_RTOL, the closed-loop critical speed to
#: DESIGN_CRITICAL_ATOL_M_S and the speed it is stable to. Never K's coefficients: the optimum is
#: flat along a direction of K (measured on the quick card: a2 0.2726 on one CPU, 0.2806 on an
#: AVX-512 one, the critical speed 1.2e-3 m/s and the margin 1.2 % apart), so they depend on the
#: path and compare nothing a user relies on. One recording per case, on any CPU.
DESIGN_CASES = {"optimise_quick", "optimise_quick_b1425"}
#: 2 %: the verified margin of a converged design lies within the card's robust_cut_tol (1 %)
#: of the optimiser's bound, so two paths to one design may differ by up to twice that
#: (measured 1.2 % across CPUs); a change of the design problem (a constraint, a weight, the
#: model) moves it by more (the buffeting weight 0 -> 3: 9 %).
DESIGN_RTOL = 0.02
#: 0.05 m/s: the closed-loop critical speed of one design reached by another path (other CPU,
#: a 1e-9 perturbation of the model) moved by 1.2e-3 m/s at most (the convergence matrix,
#: ``python -m bench.reproducible``); a 1 % change of an input moves it by > 0.3 m/s.
DESIGN_CRITICAL_ATOL_M_S = 0.05
#: the exact part (settings, layout, open-loop limits): as every golden number (1e-6 relative,
#: tests/project/test_golden.py RTOL)
DESIGN_EXACT_RTOL = 1e-6
#: 1 m/s: the usable speed of a design reached by another path. It is the 3 sigma flap-angle
#: crossing on the default card, where the flap RMS grows ~U^4 (6.43 deg at 65 m/s, 9.23 at
#: 70), so a few per cent of RMS from the K of another path (a2 3 % apart across CPUs, the
#: margin 1.2 %) moves the crossing by ~1/4 of that relative, < 0.5 m/s (an estimate, not a
#: measurement across CPUs); the saturated loop's holding speed is known to its bisection
#: tolerance, 0.5 m/s. A 1 % change of an input moves the open-loop speed by
#: 0.3 m/s and the flap demand by more; which limit binds is compared exactly.
DESIGN_USABLE_ATOL_M_S = 1.0


def design_summary(result: dict) -> tuple[dict, dict]:
    """``(exact, outcome)`` of a design case: the part compared to the default tolerance and
    the optimiser's outcome compared to :data:`DESIGN_RTOL` (empty unless usable)."""
    out = result["stdout"]
    lim = out.get("closed_loop_limits") or {}
    exact = {"exit_code": result["exit_code"],
             **{k: out.get(k) for k in ("status", "controller_usable", "design_modes",
                                        "flap_count", "flap_positions_m", "gain_limit",
                                        "zeta_min", "settings")},
             "acceptance": (out.get("acceptance") or {}).get("status"),
             "usable_speed_limited_by": out.get("usable_speed_limited_by"),
             **{k: lim.get(k) for k in ("open_loop_flutter_speed_m_s",
                                        "open_loop_divergence_speed_m_s")}}
    outcome = {}
    if out.get("usable_speed_m_s") is not None:   # whether usable or not: it decides that
        outcome["usable_speed_m_s"] = out["usable_speed_m_s"]
    if out.get("controller_usable"):
        outcome |= {"robust_margin": out.get("robust_margin"),
                    "closed_loop_critical_speed_m_s": lim.get("critical_speed_m_s"),
                    "closed_loop_stable_to_m_s": out.get("closed_loop_stable_to_m_s")}
    return exact, outcome


def design_outcome_diffs(golden: dict, new: dict) -> list[str]:
    """Differences of a design case against its recording on :func:`design_summary`: the
    exact part to :data:`RTOL`, the margin to :data:`DESIGN_RTOL`, the critical speed to
    :data:`DESIGN_CRITICAL_ATOL_M_S`."""
    (g_exact, g_out), (n_exact, n_out) = design_summary(golden), design_summary(new)
    out = compare(g_exact, n_exact, DESIGN_EXACT_RTOL)
    if set(g_out) != set(n_out):
        return out + [f"usable (or with a usable speed) in one only: {sorted(g_out)} != "
                      f"{sorted(n_out)}"]
    if "usable_speed_m_s" in g_out:
        out += compare(g_out["usable_speed_m_s"], n_out["usable_speed_m_s"], 0.0,
                       "/usable_speed_m_s", atol=DESIGN_USABLE_ATOL_M_S)
    if "robust_margin" in g_out:
        out += compare(g_out["robust_margin"], n_out["robust_margin"], DESIGN_RTOL,
                       "/robust_margin")
        out += compare(g_out["closed_loop_critical_speed_m_s"],
                       n_out["closed_loop_critical_speed_m_s"], 0.0,
                       "/closed_loop_critical_speed_m_s", atol=DESIGN_CRITICAL_ATOL_M_S)
        out += compare(g_out["closed_loop_stable_to_m_s"], n_out["closed_loop_stable_to_m_s"],
                       0.0, "/closed_loop_stable_to_m_s", atol=DESIGN_CRITICAL_ATOL_M_S)
    return out
