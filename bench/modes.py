"""Benchmark of structural assembly and eigen-solution against mesh size.

Run ``python -m bench.modes`` (table) or ``python -m bench.modes --json`` (one JSON object).

For each element length the bridge (complete, default Humber) is assembled
(:func:`bridgeflap.model.structure.cable.dead_load` +
:func:`bridgeflap.model.structure.fe.assemble`) and the lowest ``k`` modes of each family are
computed three ways:

* ``dense``: :func:`scipy.linalg.eigh` on the full generalised problem (what
  :func:`bridgeflap.model.structure.modes.solve` does; the reference);
* ``sparse``: :func:`scipy.sparse.linalg.eigsh` in shift-invert mode (``sigma = 0``) on the
  assembled matrices stored as CSC. The vertical and torsional stiffnesses carry Irvine's global
  rank-one cable-stretching term ``c g g^T``, so they are essentially *full*: the ``fill``
  column shows it, and SuperLU then factors a dense matrix;
* ``sparse+SM`` (vertical, torsional): the same shift-invert, but ``K^-1`` applied as a
  Sherman-Morrison update ``K = B + u u^T`` of the banded part ``B`` (sparse LU of ``B`` only).
  ``B`` is obtained by re-assembling with the cable modulus scaled by 1e-12 and ``u u^T = K - B``
  exactly (for the complete bridge ``H`` and ``L_E`` do not depend on ``EA``).

Memory is the peak traced by :mod:`tracemalloc` (allocations made through Python/numpy, which
includes LAPACK workspaces allocated by scipy's wrappers) plus, for the sparse methods, the
bytes of SuperLU's ``L`` and ``U`` factors (allocated in C, invisible to tracemalloc):
``12 * (nnz(L) + nnz(U))`` (float64 value + int32 index). Timings are the best of ``--repeat``
runs outside tracemalloc. OpenBLAS threading on a loaded machine can slow dense LAPACK calls by
an order of magnitude; the table header reports ``OPENBLAS_NUM_THREADS``/``OMP_NUM_THREADS``.
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
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np
import scipy
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from bridgeflap.design.io.files import to_jsonable
from bridgeflap.model.structure import cable, fe
from bridgeflap.model.structure.loader import load_bridge
from bridgeflap.model.structure.spec import BridgeSpec

FAMILIES = ("vertical", "torsional", "lateral")


@dataclass
class Row:
    """One (mesh, family, method) measurement; NaN where a method was not run."""

    element_length_m: float
    n_elements: int
    family: str
    n_dof: int
    method: str
    status: str
    assembly_s: float
    assembly_peak_mb: float
    stiffness_fill: float
    solve_s: float
    solve_peak_mb: float
    time_ratio: float
    memory_ratio: float
    max_rel_freq_diff: float
    lowest_hz: float


def _measure(fn, repeat: int):
    """(result, best wall time [s], peak traced memory [MB]) of ``fn()``."""
    best = float("inf")
    out = None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    tracemalloc.start()
    tracemalloc.reset_peak()
    try:
        fn()
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    return out, best, peak / 1e6


def _dense(K, M, k):
    w2 = sla.eigh(K, M, eigvals_only=True)
    return np.sort(w2)[:k]


def _lu_bytes(A_csc) -> int:
    lu = spla.splu(A_csc)
    return 12 * (lu.L.nnz + lu.U.nnz)


def _sparse(K, M, k):
    Ks, Ms = sp.csc_matrix(K), sp.csc_matrix(M)
    w2 = spla.eigsh(Ks, k=k, M=Ms, sigma=0.0, which="LM", return_eigenvectors=False)
    return np.sort(w2)


def _sparse_sm(B, u, M, k):
    """Shift-invert with K^-1 b = B^-1 b - B^-1 u (u^T B^-1 b) / (1 + u^T B^-1 u)."""
    Bs, Ms = sp.csc_matrix(B), sp.csc_matrix(M)
    lu = spla.splu(Bs)
    z = lu.solve(u)
    denom = 1.0 + float(u @ z)

    def apply(b):
        y = lu.solve(np.asarray(b, dtype=float).ravel())
        return y - z * (float(u @ y) / denom)

    n = B.shape[0]
    opinv = spla.LinearOperator((n, n), matvec=apply, dtype=float)
    a_op = spla.LinearOperator((n, n), matvec=lambda x: Bs @ x + u * float(u @ x), dtype=float)
    w2 = spla.eigsh(a_op, k=k, M=Ms, sigma=0.0, which="LM", OPinv=opinv,
                    return_eigenvectors=False)
    return np.sort(w2)


def _rank_one_split(K, K_b):
    """``(B, u)`` with ``K = B + u u^T`` where ``K - K_b`` is rank one."""
    D = K - K_b
    j = int(np.argmax(np.diag(D)))
    u = D[:, j] / np.sqrt(D[j, j])
    return K - np.outer(u, u), u


def _freq_hz(w2):
    return np.sqrt(np.maximum(w2, 0.0)) / (2 * np.pi)


def bench_mesh(spec: BridgeSpec, element_length_m: float, k: int, repeat: int) -> list[Row]:
    """All rows for one element length."""
    s = spec.replace(**{"mesh.element_length_m": element_length_m})

    def build():
        return fe.assemble(s, cable.dead_load(s))

    structure, t_asm, mem_asm = _measure(build, repeat)
    weak = fe.assemble(s.replace(**{"cable.modulus_pa": s.cable.modulus_pa * 1e-12}))
    n_el = len(structure.elements)
    rows = []
    for name in FAMILIES:
        fam = structure.families[name]
        K, M = fam.K, fam.M
        n = K.shape[0]
        fill = float(np.count_nonzero(K)) / K.size
        common = dict(element_length_m=element_length_m, n_elements=n_el, family=name,
                      n_dof=n, assembly_s=t_asm, assembly_peak_mb=mem_asm,
                      stiffness_fill=fill)
        ref, t_d, m_d = _measure(lambda K=K, M=M: _dense(K, M, k), repeat)
        f_ref = _freq_hz(ref)
        rows.append(Row(method="dense", status="ok", solve_s=t_d, solve_peak_mb=m_d,
                        time_ratio=1.0, memory_ratio=1.0, max_rel_freq_diff=0.0,
                        lowest_hz=float(f_ref[0]), **common))
        methods = [("sparse", lambda K=K, M=M: _sparse(K, M, k), sp.csc_matrix(K))]
        if name != "lateral":
            B, u = _rank_one_split(K, weak.families[name].K)
            methods.append(("sparse+SM", lambda B=B, u=u, M=M: _sparse_sm(B, u, M, k),
                            sp.csc_matrix(B)))
        for method, fn, factored in methods:
            if k >= n - 1:
                rows.append(Row(method=method, status=f"skipped: k={k} >= n_dof-1",
                                solve_s=np.nan, solve_peak_mb=np.nan, time_ratio=np.nan,
                                memory_ratio=np.nan, max_rel_freq_diff=np.nan,
                                lowest_hz=np.nan, **common))
                continue
            try:
                w2, t_s, m_s = _measure(fn, repeat)
                m_s += _lu_bytes(factored) / 1e6
                f = _freq_hz(w2)
                diff = float(np.max(np.abs(f / f_ref - 1.0)))
                rows.append(Row(method=method, status="ok", solve_s=t_s, solve_peak_mb=m_s,
                                time_ratio=t_s / t_d, memory_ratio=m_s / m_d,
                                max_rel_freq_diff=diff, lowest_hz=float(f[0]), **common))
            except (RuntimeError, ValueError, spla.ArpackError) as exc:
                rows.append(Row(method=method, status=f"failed: {exc}", solve_s=np.nan,
                                solve_peak_mb=np.nan, time_ratio=np.nan, memory_ratio=np.nan,
                                max_rel_freq_diff=np.nan, lowest_hz=np.nan, **common))
    return rows


def _git_commit() -> str | None:
    try:
        out = subprocess.run(["git", "rev-parse", "HEAD"], capture_output=True, text=True,
                             cwd=Path(__file__).parent, timeout=10, check=True)
        return out.stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return None


def run(bridge: str, element_lengths, k: int, repeat: int) -> dict:
    """Benchmark result as a JSON-ready dict (config, environment, rows)."""
    spec = load_bridge(bridge)
    rows = []
    for h in element_lengths:
        rows.extend(bench_mesh(spec, float(h), k, repeat))
    return {
        "config": {"bridge": bridge, "element_lengths_m": [float(h) for h in element_lengths],
                   "k": k, "repeat": repeat},
        "environment": {"python": platform.python_version(), "numpy": np.__version__,
                        "scipy": scipy.__version__, "git_commit": _git_commit(),
                        "OPENBLAS_NUM_THREADS": os.environ.get("OPENBLAS_NUM_THREADS"),
                        "OMP_NUM_THREADS": os.environ.get("OMP_NUM_THREADS"),
                        "cpu_count": os.cpu_count()},
        "rows": [asdict(r) for r in rows],
    }


def format_table(result: dict) -> str:
    """Plain-text table of :func:`run`'s result."""
    env = result["environment"]
    lines = [
        f"bridgeflap bench.modes: {result['config']['bridge']}, lowest "
        f"{result['config']['k']} modes per family; numpy {env['numpy']}, scipy {env['scipy']}, "
        f"OPENBLAS_NUM_THREADS={env['OPENBLAS_NUM_THREADS']}, cpus={env['cpu_count']}",
        "ratios are against the dense eigh of the same family and mesh; memory = tracemalloc "
        "peak (+ SuperLU factors for sparse)",
        f"{'h [m]':>6} {'n_el':>5} {'asm [s]':>8} {'asm MB':>7} {'family':<10} {'n_dof':>5} "
        f"{'fill':>5} {'method':<10} {'solve [s]':>9} {'MB':>7} {'t/dense':>8} {'mem/dense':>9} "
        f"{'max|df|/f':>9}",
    ]
    for r in result["rows"]:
        if not r["status"].startswith(("ok",)):
            lines.append(f"{r['element_length_m']:6.2f} {r['n_elements']:5d} {'':>8} {'':>7} "
                         f"{r['family']:<10} {r['n_dof']:5d} {'':>5} {r['method']:<10} "
                         f"{r['status']}")
            continue
        lines.append(
            f"{r['element_length_m']:6.2f} {r['n_elements']:5d} {r['assembly_s']:8.3f} "
            f"{r['assembly_peak_mb']:7.2f} {r['family']:<10} {r['n_dof']:5d} "
            f"{r['stiffness_fill']:5.2f} {r['method']:<10} {r['solve_s']:9.4f} "
            f"{r['solve_peak_mb']:7.2f} {r['time_ratio']:8.3f} {r['memory_ratio']:9.3f} "
            f"{r['max_rel_freq_diff']:9.1e}")
    return "\n".join(lines)


def main(argv=None) -> int:
    """Command-line entry point."""
    p = argparse.ArgumentParser(prog="python -m bench.modes", description=__doc__.split("\n")[0])
    p.add_argument("--bridge", default="humber", help="built-in name or path to a .toml file")
    p.add_argument("--element-lengths", type=float, nargs="+", default=[50.0, 25.0, 12.5, 6.25],
                   help="target element lengths [m]")
    p.add_argument("-k", "--modes", type=int, default=20, help="modes per family")
    p.add_argument("--repeat", type=int, default=1, help="timing repeats (best is kept)")
    p.add_argument("--json", action="store_true", help="print one JSON object instead")
    a = p.parse_args(argv)
    result = run(a.bridge, a.element_lengths, a.modes, a.repeat)
    if a.json:
        print(json.dumps(to_jsonable(result), allow_nan=False))
    else:
        print(format_table(result))
    return 0


if __name__ == "__main__":
    sys.exit(main())
