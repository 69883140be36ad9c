"""Update the unsourced Great Belt stiffnesses (EI vertical, GJ, EI lateral) to the IABSE step-2a
modal model (model/bridges/great_belt.toml, docs/great_belt.md#updating).

One family at a time (the FE families are uncoupled), bounded Brent search on log10 of the
stiffness minimising the RMS log misfit of the paired modes: the step-2a main-span modes paired
with the FE main-span modes by (family, symmetry, order) --
``bridgeflap.model.structure.modal_import`` compare rows. Run: ``python
runs/great_belt_updating/run.py``; prints one JSON object: the updated values to put in the TOML,
the misfits and the mode comparison (tests/test_runs.py checks that the values are the ones in
model/bridges/great_belt.toml).
"""

import json

import numpy as np
from scipy.optimize import minimize_scalar

from bridgeflap.model.analysis import modal_model
from bridgeflap.model.structure.loader import load_bridge
from bridgeflap.model.structure.modal_import import compare_modes

#: the step-2a modes each family is updated to (the surely paired ones, docs/great_belt.md)
TARGETS = {"vertical": ("deck.ei_vertical_nm2", ("VA1", "VS1", "VS2", "VA2"), (10.0, 14.0)),
           "torsional": ("deck.gj_nm2", ("TS1", "TA1"), (10.0, 13.5)),
           "lateral": ("deck.ei_lateral_nm2", ("LS1", "LA1"), (11.0, 16.0))}


def misfit(spec, reference, labels):
    rows = {r["label"]: r for r in compare_modes(modal_model(spec), reference)}
    return float(np.sqrt(np.mean([np.log(rows[lab]["ratio"]) ** 2 for lab in labels])))


def main():
    spec = load_bridge("great-belt")
    ref = modal_model(load_bridge("iabse-2a"))
    out = {"bridge": spec.name, "updated": {}}
    for path, labels, bounds in TARGETS.values():
        res = minimize_scalar(lambda v, p=path, s=spec, lab=labels: misfit(
            s.replace(**{p: 10 ** v}), ref, lab), bounds=bounds, method="bounded",
            options={"xatol": 1e-4})
        spec = spec.replace(**{path: float(10 ** res.x)})
        out["updated"][path] = {"value": float(10 ** res.x), "rms_log_misfit": float(res.fun),
                                "modes": list(labels),
                                "at_bound": bool(np.isclose(res.x, bounds).any())}
    out["comparison"] = compare_modes(modal_model(spec), ref)
    print(json.dumps(out))


if __name__ == "__main__":
    main()
