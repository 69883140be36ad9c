"""Start-up of the ``bridgeflap`` CLI: import time, wall time, what loads.

For each command, in a fresh interpreter, best of ``--repeat``: the wall time of the whole
command, the import time (``python -X importtime``: the sum of the top-level cumulative times)
and which of the heavy packages (CasADi, matplotlib, Dask, SALib, pandas, xarray, SciPy's
optimize and special) were imported. ``--checkout DIR`` runs another source tree (e.g. the
main checkout) for a before/after table. The machine is often shared: the load is printed.

    OPENBLAS_NUM_THREADS=1 python -m bench.startup [--repeat 5] [--checkout /work/main]
"""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
COMMANDS = (("modes", "--json"), ("flutter", "--json"), ("rfa", "--json"))
HEAVY = ("casadi", "matplotlib", "dask", "distributed", "SALib", "pandas", "xarray",
         "scipy.optimize", "scipy.special")
_PROBE = ("import sys, runpy; sys.argv = ['bridgeflap', *sys.argv[1:]]\n"
          "try:\n    runpy.run_module('bridgeflap.design.cli.main', run_name='__main__')\n"
          "except SystemExit:\n    pass\n"
          f"print('LOADED', ','.join(m for m in {HEAVY!r} if m in sys.modules), "
          "file=sys.stderr)\n")


def measure(tree: Path, argv: tuple, repeat: int) -> dict:
    env = {**os.environ, "PYTHONPATH": str(tree), "OPENBLAS_NUM_THREADS": "1",
           "MPLBACKEND": "Agg"}
    walls, imports, loaded = [], [], ""
    for _ in range(repeat):
        t = time.perf_counter()
        subprocess.run([sys.executable, "-m", "bridgeflap.design.cli.main", *argv], cwd=tree,
                       env=env,
                       capture_output=True, check=True)
        walls.append(time.perf_counter() - t)
        p = subprocess.run([sys.executable, "-X", "importtime", "-c", _PROBE, *argv], cwd=tree,
                           env=env, capture_output=True, text=True, check=True)
        top = [int(m.group(1)) for m in re.finditer(r"import time:\s+\d+ \|\s+(\d+) \| (\S)",
                                                      p.stderr)]
        imports.append(sum(top) / 1e6)
        loaded = next((ln.split(" ", 1)[1] for ln in p.stderr.splitlines()
                       if ln.startswith("LOADED")), "")
    return {"wall_s": min(walls), "import_s": min(imports), "heavy": loaded or "-"}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--checkout", default=None, help="another source tree to compare")
    args = ap.parse_args()
    trees = [("this", ROOT)] + ([("other", Path(args.checkout))] if args.checkout else [])
    load = "/".join(f"{x:.2f}" for x in os.getloadavg())
    print(f"bridgeflap start-up, best of {args.repeat}; {os.cpu_count()} CPUs; load {load}")
    print(f"  {'command':14s} {'tree':6s} {'wall [s]':>9s} {'imports [s]':>12s}  heavy imports")
    for argv in COMMANDS:
        for name, tree in trees:
            r = measure(tree, argv, args.repeat)
            print(f"  {' '.join(argv[:1]):14s} {name:6s} {r['wall_s']:9.3f} {r['import_s']:12.3f}"
                  f"  {r['heavy']}")
    load = "/".join(f"{x:.2f}" for x in os.getloadavg())
    print(f"  load at the end {load}; trees: this = {ROOT}"
          + (f", other = {args.checkout}" if args.checkout else ""))


if __name__ == "__main__":
    main()
