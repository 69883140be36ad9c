"""How far a single design can reach on the do-no-harm uncertainty set.

The default design is stable to 85 m/s on 73 % of 200 fresh variants, and every variant that
misses 85 m/s has GJ below the nominal (README, "Control"). This asks whether *any* design with
the default card's limits (3 m flaps, gain <= 15, zeta_min, 25 candidate pairs with placement)
is stable to 85 m/s on a bridge whose GJ lies low in the range, everything else nominal: the
full default design (`bridgeflap.design.control.search.driver.design`, the packaged card) is run on
each GJ given. A GJ at which no design verifies bounds the fraction of the uncertainty set that any
single controller can hold to 85 m/s from above.

    python runs/robust_limit/run.py [--gj 4.7e11,5.0e11] [--json] [--quick]

``--quick`` (or ``BRIDGEFLAP_QUICK=1``): the 47 m mesh and
:func:`bridgeflap.design.control.settings.quick_settings` (CI; not the README's numbers).

Each design takes ~5-15 min on the 2-core machine (two starts in two processes).
"""

import argparse
import json
import os
import sys
import time

from bridgeflap.design.control.search.driver import design
from bridgeflap.design.control.settings import DEFAULT_CARD, load_settings, quick_settings
from bridgeflap.design.io.files import to_jsonable
from bridgeflap.model.structure.loader import load_bridge


def row(gj: float, quick: bool = False) -> dict:
    """The default card's design on humber with ``deck.gj_nm2 = gj``."""
    t0 = time.perf_counter()
    settings, changes = load_settings(DEFAULT_CARD), {"deck.gj_nm2": float(gj)}
    if quick:
        settings, changes = quick_settings(settings), changes | {"mesh.element_length_m": 47.0}
    res = design(settings, bridge=load_bridge("humber").replace(**changes),
                 progress=lambda m: print(m, file=sys.stderr, flush=True), progress_bar=False)
    s = res.summary()
    lim = s.get("closed_loop_limits") or {}
    best = s.get("best_achievable") or {}
    return {"gj_nm2": float(gj), "status": s["status"],
            "controller_usable": s["controller_usable"], "flap_count": s["flap_count"],
            "max_gain": s["max_gain"], "robust_margin": s["robust_margin"],
            "open_loop_flutter_speed_m_s": lim.get("open_loop_flutter_speed_m_s"),
            "open_loop_divergence_speed_m_s": lim.get("open_loop_divergence_speed_m_s"),
            "closed_loop_governing_speed_m_s": lim.get("governing_speed_m_s"),
            "closed_loop_governing_mechanism": lim.get("governing_mechanism"),
            "why_not_usable": best.get("why_not_usable", []),
            "coefficients": s["coefficients"], "wall_time_s": time.perf_counter() - t0}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--gj", default="4.7e11,5.0e11",
                    help="GJ values [N m^2], comma-separated (the set's range: 4.7e11-7.1e11)")
    ap.add_argument("--json", action="store_true", help="print one JSON object on stdout")
    ap.add_argument("--quick", action="store_true",
                    help="coarse mesh, one start, quick settings (or BRIDGEFLAP_QUICK=1)")
    a = ap.parse_args(argv)
    quick = a.quick or os.environ.get("BRIDGEFLAP_QUICK", "") not in ("", "0")
    rows = [row(float(g), quick) for g in a.gj.split(",")]
    if a.json:
        print(json.dumps(to_jsonable({"rows": rows, "card": str(DEFAULT_CARD),
                                       "quick": quick}),
                         allow_nan=False))
    else:
        print(f"{'GJ [N m2]':>10} {'status':>11} {'margin':>8} {'open-loop':>10} "
              f"{'closed-loop':>12}  mechanism")
        for r in rows:
            ol = min(v for v in (r["open_loop_flutter_speed_m_s"],
                                 r["open_loop_divergence_speed_m_s"]) if v is not None)
            print(f"{r['gj_nm2']:10.3g} {r['status']:>11} {r['robust_margin']:8.4f} "
                  f"{ol:10.2f} {r['closed_loop_governing_speed_m_s'] or float('nan'):12.2f}  "
                  f"{r['closed_loop_governing_mechanism']}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
