"""Sensitivity study of the Humber flutter and divergence speeds.

1. Local: exact derivatives by the implicit-function theorem, checked by finite differences of
   the fully re-solved pipeline, and a tornado plot of the relative derivatives.
2. Global: Morris elementary effects over the stated ranges of the estimated inputs
   (bridgeflap.design.studies.screening.DEFAULT_UNCERTAIN_RANGES), run through the DOE batch runner;
   indices and the 5/50/95 % band of both speeds.

    python runs/sensitivity/run.py [--quick] [--out DIR] [--workers N] [--method morris|sobol]

Output (default: output/ next to this script): local.json, global.json, tornado.png,
global.png, manifest.json and the batch folder gsa/.
"""

import argparse
import json
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from bridgeflap.design.io.files import atomic_write_json, ensure_writable_dir  # noqa: E402
from bridgeflap.design.io.manifest import build_manifest  # noqa: E402
from bridgeflap.design.sensitivity.local import DEFAULT_PARAMETERS, local_sensitivity  # noqa: E402
from bridgeflap.design.studies.screening import DEFAULT_UNCERTAIN_RANGES, global_sensitivity  # noqa: E402
from bridgeflap.model.structure.loader import load_bridge  # noqa: E402


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="coarse mesh, few modes, small sample")
    ap.add_argument("--out", default=str(Path(__file__).parent / "output"))
    ap.add_argument("--workers", type=int, default=1)
    ap.add_argument("--scheduler", default=None, help="Dask address or 'serial'")
    ap.add_argument("--method", choices=("morris", "sobol"), default="morris")
    args = ap.parse_args()
    out = ensure_writable_dir(args.out)
    config = {"quick": args.quick, "method": args.method,
              "ranges": {k: list(v) for k, v in DEFAULT_UNCERTAIN_RANGES.items()}}
    spec = load_bridge("humber")
    if args.quick:
        spec = spec.replace(**{"mesh.element_length_m": 47.0})
        params, modes, speeds = ("deck.gj_nm2", "cable.main_sag_m", "deck.half_chord_m"), 8, \
            "0:120:2"
        n = 2 if args.method == "morris" else 4
    else:
        params, modes, speeds = DEFAULT_PARAMETERS, 16, "0:120:1"
        n = 10 if args.method == "morris" else 64
    config.update({"parameters": list(params), "modes": modes, "speeds": speeds, "n": n})
    atomic_write_json(out / "manifest.json", build_manifest(config))

    local = local_sensitivity(spec, params, speeds=speeds, n_modes=modes)
    print(local.table())
    atomic_write_json(out / "local.json", local.summary())
    fig = local.plot()
    fig.savefig(out / "tornado.png", dpi=110, bbox_inches="tight")
    plt.close(fig)

    case_options = {"speeds": speeds, "modes": modes}
    gsa = global_sensitivity("humber", DEFAULT_UNCERTAIN_RANGES, method=args.method, n=n,
                             out_dir=out / "gsa", workers=args.workers, scheduler=args.scheduler,
                             case_options=case_options, progress=False)
    atomic_write_json(out / "global.json", gsa.summary())
    fig = gsa.plot()
    fig.savefig(out / "global.png", dpi=110, bbox_inches="tight")
    plt.close(fig)
    print(json.dumps({"band": gsa.band, "cases": gsa.cases, "failed": gsa.failed},
                     default=float, indent=1))


if __name__ == "__main__":
    main()
