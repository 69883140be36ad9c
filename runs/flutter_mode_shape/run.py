"""The flutter mode of the built-in Humber along the span, and the frequency-ratio modes.

Renders two figures (model/stability/modeshape.py):

* ``flutter_mode_shape.png``: heave and pitch amplitude and their phase along the bridge at the
  flutter speed (16 modes, 0-85 m/s grid as ``bridgeflap flutter``), towers marked, with the
  kinetic-energy shares of the retained modes (the paper, §4: "mainly TS1, VS1 and VS2");
* ``ratio_modes.png``: the first symmetric vertical and torsional deck modes that the
  frequency-ratio rule (bridgeflap.model.analysis.first_symmetric_deck_mode) picks at 20, 50, 80 and
  100 % of the main-span deck (half GJ, EI = 0, the file's side-span sequence);
* ``ratio_modes_jumps.png``: the same at 30, 35, 95 and 100 %, where the rule passes over a
  TS1 split into two hybrids with the bare side-span cable and picks a higher mode;

and prints (or with ``--json`` writes to stdout) the numbers behind them.

    python runs/flutter_mode_shape/run.py [--out DIR] [--json] [--quick]

``--quick``: coarse mesh (CI).
"""

import argparse
import json
from pathlib import Path

from bridgeflap.design.io.files import atomic_write_json, ensure_writable_dir, to_jsonable
from bridgeflap.design.io.options import parse_range
from bridgeflap.model.analysis import DEFAULT_MODES, first_symmetric_deck_mode
from bridgeflap.model.stability.modeshape import flutter_mode_shape, plot_ratio_modes, ratio_modes
from bridgeflap.model.structure.loader import load_bridge


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", default=str(Path(__file__).parent / "output"))
    ap.add_argument("--json", action="store_true")
    ap.add_argument("--quick", action="store_true")
    args = ap.parse_args()
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out = ensure_writable_dir(args.out)
    spec = load_bridge("humber")
    if args.quick:
        spec = spec.replace(**{"mesh.element_length_m": 47.0})
    shape = flutter_mode_shape(spec, parse_range("0:85:0.5", "speeds", 0.0), DEFAULT_MODES)
    fig = shape.plot()
    fig.savefig(out / "flutter_mode_shape.png", dpi=120)
    plt.close(fig)
    picked = ratio_modes(spec, first_symmetric_deck_mode, (0.2, 0.5, 0.8, 1.0))
    axes = plot_ratio_modes(picked)
    axes[0].figure.savefig(out / "ratio_modes.png", dpi=120)
    plt.close(axes[0].figure)
    # the stages where the rule passes over a hybridised TS1 (docs/humber_data.md)
    jumps = ratio_modes(spec, first_symmetric_deck_mode, (0.30, 0.35, 0.95, 1.0))
    axes = plot_ratio_modes(jumps)
    axes[0].figure.savefig(out / "ratio_modes_jumps.png", dpi=120)
    plt.close(axes[0].figure)
    result = {"flutter_mode": shape.summary(), "ratio_modes": picked.summary(),
              "ratio_modes_jumps": jumps.summary(),
              "figures": [str(out / n) for n in ("flutter_mode_shape.png", "ratio_modes.png",
                                                 "ratio_modes_jumps.png")]}
    atomic_write_json(out / "mode_shapes.json", result)
    if args.json:
        print(json.dumps(to_jsonable(result), allow_nan=False))
        return
    s = result["flutter_mode"]
    print(f"flutter {s['flutter_speed_m_s']:.3f} m/s, {s['flutter_frequency_hz']:.4f} Hz")
    print("kinetic-energy shares:",
          ", ".join(f"{k} {v:.3f}" for k, v in s["participation_kinetic_energy"].items()))
    print("strain-energy shares: ",
          ", ".join(f"{k} {v:.3f}" for k, v in s["participation_strain_energy"].items()))
    print(f"peak heave {s['peak_heave_m']:.3f} m per {s['peak_pitch_rad']} rad peak pitch; "
          f"heave phase at the pitch peak {s['heave_phase_at_peak_pitch_deg']:.1f} deg")
    for r in result["ratio_modes"] + result["ratio_modes_jumps"]:
        print(f"{100 * r['erected_fraction']:5.0f} %: {r['vertical_mode']} "
              f"{r['vertical_frequency_hz']:.4f} Hz (deck share {r['vertical_deck_share']:.3f},"
              f" uniform {r['vertical_uniform_deck_share']:.3f}); {r['torsional_mode']} "
              f"{r['torsional_frequency_hz']:.4f} Hz (deck share "
              f"{r['torsional_deck_share']:.3f}, uniform {r['torsional_uniform_deck_share']:.3f})")
    print("figures:", *result["figures"])


if __name__ == "__main__":
    main()
