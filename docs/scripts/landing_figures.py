"""The two figures of the documentation's front page (``docs/index.md``), and their numbers.

Run from the repository root (about a minute on 2 cores with the committed controller)::

    python docs/scripts/landing_figures.py

It writes ``docs/images/humber_root_locus.png`` (the built-in Humber Bridge's open-loop root
locus, V-g and V-f, 30 modes, 0-85 m/s), ``docs/images/humber_flaps.png`` (the paper's Fig. 5
drawn by ``bridgeflap study``'s report code: the closed-loop root locus over the open loop, and
buffeting with and without the flaps) and ``docs/images/landing_numbers.json`` (the speeds the
front page quotes).

The controller is ``docs/images/humber_quick_controller.toml``, the one
``bridgeflap optimise --quick --out optq`` wrote (the reduced design problem: 16 design modes,
one start; ``optq/controller.toml``). ``--controller FILE`` draws another one, for example that
of a full ``bridgeflap optimise`` run.
"""

from __future__ import annotations

import argparse
import json
import os
from pathlib import Path

os.environ.setdefault("MPLBACKEND", "Agg")

IMAGES = Path(__file__).resolve().parents[1] / "images"


def main(argv=None) -> None:
    """Draw the front page's figures into ``docs/images``."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--controller", default=str(IMAGES / "humber_quick_controller.toml"),
                        help="controller TOML (default: the committed --quick design)")
    parser.add_argument("--out", default=str(IMAGES), help="output folder")
    args = parser.parse_args(argv)
    out = Path(args.out)

    import matplotlib.pyplot as plt
    import numpy as np

    from bridgeflap import model
    from bridgeflap.design.studies.analyses import fig5

    spec = model.load_bridge("humber")
    speeds = np.arange(0.0, 85.0 + 1e-9, 0.5)
    res = model.flutter(spec, speeds, sweep_method="fast")  # 30 modes, as bridgeflap flutter
    fig = res.plot()  # root locus, V-g and V-f (FlutterResult.plot)
    fig.savefig(out / "humber_root_locus.png", dpi=90)
    plt.close(fig)

    controller = model.load_controller(args.controller)
    fig = fig5(spec, controller, quick=True, open_loop_flutter_m_s=res.flutter_speed_m_s)
    fig.suptitle(f"The paper's Fig. 5 on the built-in Humber Bridge: {controller.n_flaps} flap "
                 "pairs, the controller of bridgeflap optimise --quick (30 modes)", fontsize=11)
    fig.savefig(out / "humber_flaps.png", dpi=72)
    plt.close(fig)

    closed = model.closed_loop_flutter(spec, controller, speeds, 30).summary()
    numbers = {"command": "python docs/scripts/landing_figures.py",
               "controller": Path(args.controller).name,
               "open_loop": {k: res.summary()[k] for k in (
                   "flutter_speed_m_s", "divergence_speed_m_s", "critical_speed_m_s",
                   "critical_mechanism")},
               "closed_loop": {k: closed.get(k) for k in (
                   "flutter_status", "divergence_status", "critical_speed_m_s")}}
    numbers = json.loads(json.dumps(numbers).replace("NaN", "null"))  # strict JSON
    (out / "landing_numbers.json").write_text(json.dumps(numbers, indent=2, allow_nan=False)
                                              + "\n")
    print(json.dumps(numbers, indent=2))


if __name__ == "__main__":
    main()
