"""How far the 4-lag RFA of Theodorsen's C(k) moves flutter speeds, and the band-weighted fit.

The default ``rfa4`` (unweighted least squares on 1e-3 <= k <= 3) reads up to
0.13 % high on the 2-D flat-plate cases and 0.18 % on Humber. ``rfa4-band`` is the same form
and lag count, fitted with weight 10 on the bridge-flutter band 0.05 <= k <= 0.5
(:data:`bridgeflap.model.aero.rfa.FLUTTER_BAND_K`, :data:`bridgeflap.model.aero.rfa.BAND_WEIGHT`).
This run prints and writes:

* per case of :data:`bridgeflap.model.cases.rfa_cases.RFA_CHECK_CASES`: the exact-Theodorsen p-k
  flutter speed, each fit's RFA state-space flutter speed and its gap [%], the flutter reduced
  frequency and ``|C_rfa - C|`` there;
* the built-in Humber (16 modes, 0-85 m/s): exact p-k, ``rfa4`` and ``rfa4-band``, i.e. how
  far the default bridge's numbers would move if the package default switched;
* (not with ``--quick``) the trade-off: band weights 1, 3, 10, 30 and 1e4 and unweighted 5-
  and 6-lag fits, with their max error on 0 < k <= 3 and on the band and the largest gap.

    python runs/rfa_fit/run.py [--quick] [--json] [--out DIR]

``--quick``: the 2-D cases only (CI). Speeds of ``hp-*`` are ``U / (b omega_theta)``, the
others m/s; ``b`` is each case's deck half-chord (``half_chord_m``).
"""

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

from bridgeflap.design.io.files import atomic_write_json, ensure_writable_dir, to_jsonable
from bridgeflap.design.io.manifest import build_manifest
from bridgeflap.model import analysis
from bridgeflap.model.aero.rfa import FLUTTER_BAND_K, band_error, fit_theodorsen, get_rfa
from bridgeflap.model.cases.rfa_cases import RFA_CHECK_CASES, flutter_gap
from bridgeflap.model.stability import sweeps as stability
from bridgeflap.model.structure.loader import load_bridge

FITS = ("rfa4", "rfa4-band")
SCAN_WEIGHTS = (1.0, 3.0, 10.0, 30.0, 1e4)
SCAN_LAGS = (5, 6)
HUMBER_SPEEDS = np.arange(0.0, 85.0 + 1e-9, 0.5)   # the CLI's flutter grid [m/s]
HUMBER_PK_SPEEDS = np.arange(0.0, 85.0 + 1e-9, 2.5)  # same crossing as 0.5 m/s (test_aeroelastic)
HUMBER_TOL = 1e-5  # Brent tolerance on the crossing [m/s]: 1.4e-5 % of 69 m/s


def fit_row(approx) -> dict:
    """Coefficients and errors of one fit (JSON-ready)."""
    rep = approx.report()
    return {k: rep[k] for k in ("name", "n_lags", "gains", "poles", "fit_band_k",
                                "fit_band_weight", "max_error", "k_at_max_error",
                                "max_error_in_flutter_band")}


def humber(fits) -> dict:
    """Humber flutter [m/s] by exact p-k and by each fit, 16 modes, modal lag order."""
    spec = load_bridge("humber")
    modal, system = analysis.bridge_system(spec, analysis.DEFAULT_MODES)
    pk = stability.pk_sweep(system, HUMBER_PK_SPEEDS, speed_tol=HUMBER_TOL)
    ue = float(pk.flutter.speed)
    b = spec.deck.half_chord_m
    out = {"bridge": "humber", "n_modes": analysis.DEFAULT_MODES, "half_chord_m": b,
           "exact_flutter_speed_m_s": ue, "exact_flutter_status": pk.flutter.status,
           "exact_reduced_frequency": float(2 * np.pi * pk.flutter.frequency_hz * b / ue),
           "rfa": {}}
    for f in fits:
        r = analysis.flutter(spec, HUMBER_SPEEDS, rfa=f, speed_tol=HUMBER_TOL)
        u = float(r.sweep.flutter.speed)
        out["rfa"][f] = {"flutter_speed_m_s": u, "flutter_status": r.sweep.flutter.status,
                         "flutter_frequency_hz": float(r.sweep.flutter.frequency_hz),
                         "gap_percent": float(100 * (u / ue - 1))}
    return out


def scan(humber_too: bool) -> list[dict]:
    """Band weights and lag counts: errors of C and the largest flutter-speed gap."""
    fits = [fit_theodorsen(4, 3.0, FLUTTER_BAND_K, w) for w in SCAN_WEIGHTS]
    fits += [fit_theodorsen(n) for n in SCAN_LAGS]
    gaps = {f.name: {} for f in fits}
    for case in RFA_CHECK_CASES:
        res = flutter_gap(case, fits)
        for name, v in res["rfa"].items():
            gaps[name][case] = v["gap_percent"]
    if humber_too:
        from bridgeflap.model.aeroelastic import statespace

        spec = load_bridge("humber")
        modal, system = analysis.bridge_system(spec, analysis.DEFAULT_MODES)
        ue = stability.pk_sweep(system, HUMBER_PK_SPEEDS, speed_tol=HUMBER_TOL).flutter.speed
        basis = modal.structural_basis(analysis.DEFAULT_MODES)
        for f in fits:
            s = statespace.spec_system(spec, basis, rfa=f)
            u = stability.sweep(s, HUMBER_SPEEDS, speed_tol=HUMBER_TOL).flutter.speed
            gaps[f.name]["humber"] = float(100 * (u / ue - 1))
    rows = []
    for f in fits:
        two_d = [abs(gaps[f.name][c]) for c in RFA_CHECK_CASES]
        rows.append({"name": f.name, "n_lags": f.n_lags, "fit_band_k": f.fit_band,
                     "fit_band_weight": f.band_weight, "max_error": f.max_error,
                     "max_error_in_flutter_band": band_error(f, FLUTTER_BAND_K),
                     "max_abs_gap_2d_percent": max(two_d), "gap_percent": gaps[f.name]})
    return rows


def table(cases, hum, scan_rows) -> str:
    """The printed tables."""
    lines = [f"{'case':14s} {'k_F':>6s} {'exact':>11s} " + " ".join(
        f"{f:>11s} {'gap %':>8s} {'|dC|':>7s}" for f in FITS)]
    for c in cases:
        cells = [f"{c['case']:14s} {c['exact_reduced_frequency']:6.3f} "
                 f"{c['exact_flutter_speed']:11.5f}"]
        for f in FITS:
            r = c["rfa"][f]
            cells.append(f"{r['flutter_speed']:11.5f} {r['gap_percent']:+8.4f} "
                         f"{r['c_error_at_flutter']:7.1e}")
        lines.append(" ".join(cells))
    if hum is not None:
        lines.append(f"{'humber':14s} {hum['exact_reduced_frequency']:6.3f} "
                     f"{hum['exact_flutter_speed_m_s']:11.5f} " + " ".join(
                         f"{hum['rfa'][f]['flutter_speed_m_s']:11.5f} "
                         f"{hum['rfa'][f]['gap_percent']:+8.4f} {'':7s}" for f in FITS))
    if scan_rows:
        lines += ["", f"{'fit':28s} {'max|dC|':>8s} {'band':>8s} {'max|gap| 2-D %':>15s} "
                  f"{'humber %':>9s}"]
        for r in scan_rows:
            lines.append(f"{r['name']:28s} {r['max_error']:8.2e} "
                         f"{r['max_error_in_flutter_band']:8.2e} "
                         f"{r['max_abs_gap_2d_percent']:15.4f} "
                         f"{r['gap_percent'].get('humber', float('nan')):+9.4f}")
    return "\n".join(lines)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true", help="2-D cases only (CI)")
    ap.add_argument("--json", action="store_true")
    ap.add_argument("--out", default=str(Path(__file__).parent / "output"))
    args = ap.parse_args()
    out = ensure_writable_dir(args.out)
    t0 = time.perf_counter()
    config = {"fits": list(FITS), "cases": list(RFA_CHECK_CASES), "quick": args.quick,
              "flutter_band_k": list(FLUTTER_BAND_K), "scan_band_weights": list(SCAN_WEIGHTS),
              "scan_lags": list(SCAN_LAGS)}
    cases = [flutter_gap(c, FITS) for c in RFA_CHECK_CASES]
    print(f"2-D cases done ({time.perf_counter() - t0:.1f} s)", file=sys.stderr)
    hum = None if args.quick else humber(FITS)
    rows = [] if args.quick else scan(True)
    result = {"manifest": build_manifest(config),
              "fits": [fit_row(get_rfa(f)) for f in FITS], "cases": cases,
              "max_abs_gap_2d_percent": {f: max(abs(c["rfa"][f]["gap_percent"]) for c in cases)
                                         for f in FITS},
              "humber": hum, "scan": rows, "elapsed_s": time.perf_counter() - t0}
    atomic_write_json(out / "rfa_fit.json", result)
    if args.json:
        print(json.dumps(to_jsonable(result), allow_nan=False))
        return
    print(table(cases, hum, rows))
    print(f"wrote {out / 'rfa_fit.json'}")


if __name__ == "__main__":
    main()
