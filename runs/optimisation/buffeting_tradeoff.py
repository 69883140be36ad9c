"""Buffeting trade-off of the compensator design: weight_buffeting swept.

For each buffeting weight the default design (``runs/humber_flaps.toml``: its starts, cuts
and checks; the CasADi spectral buffeting integral in modal coordinates
``buffeting_term = "modal"``,
:class:`bridgeflap.design.control.formulation.buffeting_term.ModalBuffeting`, same-K flap-count
search limited to the design count) is run through
:func:`bridgeflap.design.control.search.driver.design`; the table holds the closed-loop / open-loop
RMS ratios (vertical and torsional, numpy :func:`bridgeflap.model.response.buffeting.buffeting` on
the verification model, max over the main span) at the buffeting speeds, the robust margin, the
closed-loop critical speed and the status.

Writes ``tradeoff.csv``, ``tradeoff.md`` and ``tradeoff.png`` to ``--out`` (default
``runs/optimisation/buffeting_tradeoff``).

    python runs/optimisation/buffeting_tradeoff.py [--weights 0 1 3 10 30] [--out DIR]
"""

import argparse
import json
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from bridgeflap.design.control.search.driver import design
from bridgeflap.design.control.settings import load_settings

DEFINITION = Path(__file__).resolve().parents[1] / "humber_flaps.toml"
WEIGHTS = (0.0, 1.0, 3.0, 10.0, 30.0)


def one(settings, weight) -> dict:
    """One design at ``weight``: its row of the table."""
    s = replace(settings, weight_buffeting=float(weight), buffeting_term="modal",
                min_flap_counts=(settings.flap_count,))
    t0 = time.perf_counter()
    r = design(s, progress_bar=False)
    row = {"weight_buffeting": float(weight), "status": r.status,
           "time_s": round(time.perf_counter() - t0, 1)}
    b = r.extras.get("buffeting")
    if b is not None and b.status == "ok":
        for k, u in enumerate(b.speeds_m_s):
            row[f"rms_vertical_ratio_{u:g}_m_s"] = (b.closed_loop_rms_vertical_m[k]
                                                    / b.open_loop_rms_vertical_m[k])
            row[f"rms_torsion_ratio_{u:g}_m_s"] = (b.closed_loop_rms_torsion_rad[k]
                                                   / b.open_loop_rms_torsion_rad[k])
    best = r.best
    row["robust_margin"] = best.robust_margin if best is not None else float("nan")
    row["max_gain"] = best.max_gain if best is not None else float("nan")
    lim = r.extras.get("closed_loop_limits", {})
    row["critical_speed_m_s"] = lim.get("governing_speed_m_s", float("nan"))
    row["flutter_speed_m_s"] = lim.get("flutter_speed_m_s", float("nan"))
    row["theta"] = list(best.theta) if best is not None and best.theta else None
    return row


def plot(rows, path):
    """RMS ratios, margin and critical speed against the weight."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    w = np.array([r["weight_buffeting"] for r in rows])
    x = np.where(w > 0, w, np.min(w[w > 0]) / 3 if np.any(w > 0) else 1e-2)
    fig, ax = plt.subplots(1, 3, figsize=(13, 4))
    for key in sorted(k for k in rows[0] if k.startswith("rms_")):
        ax[0 if "vertical" in key else 1].plot(x, [r.get(key, np.nan) for r in rows], "o-",
                                               label=key.split("ratio_")[1].replace("_m_s", " m/s"))
    ax[0].set_title("vertical RMS closed/open")
    ax[1].set_title("torsional RMS closed/open")
    ax2 = ax[2].twinx()
    ax[2].plot(x, [r["robust_margin"] for r in rows], "o-", color="C0")
    ax2.plot(x, [r["critical_speed_m_s"] for r in rows], "s--", color="C3")
    ax[2].set_ylabel("robust margin [-]", color="C0")
    ax2.set_ylabel("closed-loop critical speed [m/s]", color="C3")
    ax[2].set_title("margin and critical speed")
    for a in ax:
        a.set_xscale("log")
        a.set_xlabel("weight_buffeting (0 drawn at the left end)")
        a.grid(True, which="both", alpha=0.3)
    ax[0].legend(fontsize=8)
    ax[1].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main(argv=None) -> int:
    """Sweep the weights, write the table and the figure."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--weights", type=float, nargs="+", default=list(WEIGHTS))
    ap.add_argument("--out", default=str(Path(__file__).parent / "buffeting_tradeoff"))
    args = ap.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    s = load_settings(DEFINITION)
    rows = []
    for wgt in args.weights:
        rows.append(one(s, wgt))
        print(json.dumps(rows[-1]), flush=True)
        (out / "tradeoff.json").write_text(json.dumps(rows, indent=1, allow_nan=True))
    keys = [k for k in rows[0] if k != "theta"]
    lines = [",".join(keys)] + [",".join(str(r.get(k)) for k in keys) for r in rows]
    (out / "tradeoff.csv").write_text("\n".join(lines) + "\n")
    md = ["| " + " | ".join(keys) + " |", "|" + "---|" * len(keys)]
    md += ["| " + " | ".join(f"{r.get(k):.4g}" if isinstance(r.get(k), float) else str(r.get(k))
                             for k in keys) + " |" for r in rows]
    (out / "tradeoff.md").write_text("\n".join(md) + "\n")
    plot(rows, out / "tradeoff.png")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
