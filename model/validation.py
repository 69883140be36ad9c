"""Measured Humber natural frequencies (seed Table 1, quoted from Brownjohn et al. 1994) and
the comparison of a modal model with them.

Table 1's labels are partly inconsistent (docs/humber_data.md#measured-frequencies: two "VA" rows at
0.154 and 0.177 Hz, and a first "VS" below the first "VA", which deflection theory contradicts: the
first antisymmetric vertical mode of a main span is close to sqrt(g/(8 d))/1 Hz-scale and cannot be
raised to 0.154 Hz by any plausible EI). Measured and computed modes are therefore paired
**in frequency order within each family**, using the computed modes that live mainly in the
main span (main-span share > 0.5; the measurements were taken on the main span) and, for the
lateral family, mainly in the deck rather than the cables (deck kinetic-energy share > 0.5).
"""

from __future__ import annotations

import numpy as np

# Seed Table 1: (label as printed, measured Hz, seed model Hz)
TABLE1 = {
    "vertical": [("VS", 0.117, 0.122), ("VA", 0.154, 0.116), ("VA", 0.177, 0.179),
                 ("VS", 0.218, 0.213), ("VA", 0.240, 0.242), ("VS", 0.310, 0.313)],
    "lateral": [("LS", 0.056, 0.082), ("LA", 0.141, 0.148), ("LA", 0.309, 0.295),
                ("LS", 0.418, 0.426), ("LS", 0.518, 0.535), ("LS", 0.632, 0.630)],
    "torsional": [("TS", 0.311, 0.314), ("TA", 0.482, 0.458), ("TS", 0.650, 0.696)],
}


def compare_table1(modal, share_min: float = 0.5) -> list[dict]:
    """Rows (family, Table 1 label, measured, seed model, ours, our label, difference %)."""
    rows = []
    for family, entries in TABLE1.items():
        # lateral: deck rather than cable modes (vertical/torsional deck and cables move
        # together, their deck share is the mass ratio and is not a selection criterion here)
        ours = [m for m in modal.modes if m.family == family and m.main_span_share > share_min
                and (family != "lateral" or m.deck_share > share_min)]
        ours.sort(key=lambda m: m.frequency_hz)
        measured = sorted(entries, key=lambda e: e[1])
        for k, (label, f_exp, f_seed) in enumerate(measured):
            m = ours[k] if k < len(ours) else None
            f = m.frequency_hz if m else float("nan")
            rows.append({"family": family, "table1_label": label, "measured_hz": f_exp,
                         "seed_model_hz": f_seed, "bridgeflap_hz": f,
                         "bridgeflap_label": m.label if m else "",
                         "difference_percent": 100 * (f - f_exp) / f_exp})
    return rows


def log_misfit(modal, family: str) -> float:
    """Root-mean-square of log(f_model/f_measured) over one family's paired modes."""
    rows = [r for r in compare_table1(modal) if r["family"] == family]
    d = [np.log(r["bridgeflap_hz"] / r["measured_hz"]) for r in rows]
    return float(np.sqrt(np.mean(np.square(d))))


#: Updated parameter of each family and the log10 search bounds of :func:`update_stiffnesses`.
UPDATED_PARAMETERS = {"vertical": ("deck.ei_vertical_nm2", (9.0, 14.0)),
                      "torsional": ("deck.gj_nm2", (9.0, 13.5)),
                      "lateral": ("deck.ei_lateral_nm2", (10.0, 15.0))}


def update_stiffnesses(spec, families=("vertical", "torsional", "lateral")):
    """Model updating: each family's unsourced stiffness to the measured Table 1 frequencies.

    One family at a time (the families are structurally uncoupled), the stiffness that
    minimises :func:`log_misfit` by bounded Brent search on its log10 (``xatol`` 1e-4, i.e.
    0.02 % in the value). Masses, sag and geometry are not touched.

    Returns
    -------
    (spec, report) : the updated :class:`~model.spec.BridgeSpec` and, per parameter path,
        ``{"value", "rms_log_misfit", "success", "at_bound"}``.
    """
    from scipy.optimize import minimize_scalar

    from model.modes import modal_model

    report = {}
    for family in families:
        path, bounds = UPDATED_PARAMETERS[family]

        def cost(log10_value, path=path, family=family, spec=spec):
            return log_misfit(modal_model(spec.replace(**{path: 10 ** log10_value})), family)

        res = minimize_scalar(cost, bounds=bounds, method="bounded", options={"xatol": 1e-4})
        value = float(10 ** res.x)
        spec = spec.replace(**{path: value})
        report[path] = {"value": value, "rms_log_misfit": float(res.fun),
                        "success": bool(res.success),
                        "at_bound": bool(np.isclose(res.x, bounds).any())}
    return spec, report
