"""Extract the IABSE TG3.1 step-2a tables from a checkout of knutankv/wawi as plain JSON.

Writes ``model/bridges/iabse/step2a_modes.json`` (the 12-mode modal model) and
``model/bridges/iabse/step2a_bb3_derivatives.json`` (the "BB3" flutter derivatives). The modal
model is read from wawi's JSON files; the derivative tables from the pickle
``AD_funs_BB3_scanlan.pkl`` **with pickletools only** (it walks the opcodes and executes
nothing: the file is never unpickled). Run::

    python model/bridges/iabse/step2a_extract.py /path/to/wawi   # a work tree of knutankv/wawi
"""

from __future__ import annotations

import json
import pickletools
import sys
from pathlib import Path

import numpy as np

OUT = Path(__file__).resolve().parent
COMMIT = "395f0fd"
FAMILY = ["lateral", "vertical", "vertical", "lateral", "vertical", "vertical", "vertical",
          "lateral", "torsional", "vertical", "torsional", "vertical"]


def modes(model_dir: Path) -> dict:
    d = json.loads((model_dir / "modal.json").read_text("utf-8"))
    phi = np.array(d["phi"]["full"], float).reshape(71, 6, 12)
    m, k = np.array(d["m"], float), np.array(d["k"], float)
    nodes = json.loads((model_dir / "element.json").read_text("utf-8"))["node_matrix"]
    return {
        "source": (
            "IABSE TG3.1 benchmark step 2a (12-mode full-bridge modal model, Great Belt "
            f"geometry), read from the public repository knutankv/wawi (MIT licence), commit "
            f"{COMMIT}, files tests/models/model_2a/modal.json (phi['full'], m, k) and "
            "tests/models/model_2a/element.json (node_matrix x). Plain JSON there; no pickle "
            "was read. frequency = sqrt(k/m)/(2 pi) [DERIVED]; damping_ratio 0.003 = "
            "model.modal_dry.xi0 in tests/test_IABSE_step2a.py; vertical = DOF z (index 2 of "
            "6, positive up), torsional = DOF theta_x (index 3), lateral = DOF y (index 1) at "
            "the 71 deck nodes; family per mode classified from the shapes "
            "(docs/great_belt.md). The torsional modes 9 and 11 carry a y "
            "component of 4-10 m/rad that their generalised mass does not include (M = I int "
            "theta^2 dx); it does not enter lift/moment aerodynamics."),
        "provenance": {"modal_stiffness_k": k.tolist(),
                       "k_units": "N/m (translational modes) or N m/rad (torsional modes) per "
                                  "unit modal coordinate, as in modal.json"},
        "units": {"frequency": "Hz", "length": "m", "rotation": "rad", "mass": "kg"},
        "station_x": [float(n[1]) for n in nodes],
        "frequency": (np.sqrt(k / m) / (2 * np.pi)).tolist(),
        "damping_ratio": [0.003] * 12,
        "generalised_mass": m.tolist(),
        "family": FAMILY,
        "vertical": phi[:, 2, :].tolist(),
        "torsional": phi[:, 3, :].tolist(),
        "lateral": phi[:, 1, :].tolist(),
    }


def pickle_tables(path: Path) -> dict:
    """The float64 arrays of the pickle and the names just before them (pickletools only)."""
    found, names = {}, []
    for op, arg, _pos in pickletools.genops(path.read_bytes()):
        if op.name in ("SHORT_BINUNICODE", "BINUNICODE"):
            names.append(arg)
        elif op.name == "BINBYTES" and len(arg) == 384:      # 8 x 6 float64 tables
            found[names[-1] if names[-1] != "<" else "?"] = np.frombuffer(arg, "<f8").reshape(8, 6)
    return found


def derivatives(model_dir: Path) -> dict:
    raw = pickle_tables(model_dir / "AD_funs_BB3_scanlan.pkl")
    # the opcode stream names the 2 tables of each kind "hh"/"HH_scanlan", "aa"/"AA_scanlan",
    # "pp"/"PP_scanlan"; the first array follows the dtype marker, hence the lookup by order
    arrays = list(raw.values())
    pp, PP, hh, HH, aa, AA = arrays
    vz = np.array([1.3, 1.7, 3.4, 4.5, 5.7, 10.2, 13.5, 17.0]) / (2 * np.pi)
    vt = np.array([1.7, 2.2, 3.4, 4.5, 5.7, 10.3, 13.5, 17.0]) / (2 * np.pi)
    return {
        "source": (
            "IABSE TG3.1 benchmark step 2a 'BB3' flutter derivatives, from knutankv/wawi "
            f"commit {COMMIT}, tests/models/model_2a/AD_funs_BB3_scanlan.pkl (dill-serialised "
            "functions built on scipy interp1d). Read with pickletools (opcodes only, nothing "
            "executed; the pickle was never loaded): the 8 x 6 PoliMi tables hh, aa, pp, the "
            "8 x 6 Scanlan tables HH_scanlan, AA_scanlan, PP_scanlan stored beside them, and "
            "the interp1d abscissae (vredz_w, vredth_w: reduced velocity U/(omega B), the "
            "stored vred_z, vred_th = U/(f B) over 2 pi). The functions' bytecode was not "
            "decoded; the PoliMi-to-Scanlan factors below were inferred from the stored pairs "
            "(agreement 2e-8 at every grid point). interp1d was built with bounds_error False "
            "and fill_value = the end values (constant extrapolation), linear."),
        "reduced_velocity": "v = U / (omega B), B = 31 m",
        "v_heave": vz.tolist(),
        "v_pitch": vt.tolist(),
        "abscissa_of_column": ["v_heave", "v_pitch", "v_pitch", "v_heave", "v_pitch", "v_pitch"],
        "abscissa_note": "columns 1-6 of hh and aa: h1/a1 and h4/a4 on v_heave, the others on "
                         "v_pitch; all pp columns on v_pitch (pp is constant)",
        "polimi": {"h": hh.tolist(), "a": aa.tolist(), "p": pp.tolist()},
        "scanlan_as_stored": {"H": HH.tolist(), "A": AA.tolist(), "P": PP.tolist()},
        "scanlan_from_polimi": {
            "H": ["-h1 v", "-h2 v", "h3 v^2", "h4 pi/2", "-h5 v", "h6"],
            "A": ["-a1 v", "-a2 v", "a3 v^2", "a4 pi/2", "-a5 v", "a6"],
            "P": ["-p5 v", "-p2 v", "p3 v^2", "p4", "-p1 v", "p6"]},
        "wawi_test_sign_flips": (
            "tests/test_IABSE_step2a.py AD_dict negates A1, A4, A5, A6, H2, H3, P2, P3 of the "
            "stored Scanlan functions before use (wawi's load matrices: K = 0.5 rho B^2 w^2 "
            "[[P4, P6, -B P3], [H6, H4, -B H3], [-B A6, -B A4, B^2 A3]], C = 0.5 rho B^2 w "
            "[[P1, P5, -B P2], [H5, H1, -B H2], [-B A5, -B A1, B^2 A2]] on (y, z, theta), "
            "wawi.wind.K_from_ad/C_from_ad)"),
        "check": (
            "with step2a_modes.json, rho = 1.22, xi = 0.3 % and wawi's p-k formulation: "
            "flutter 69.86 m/s at 0.2175 Hz (reference 69.8 m/s); TS1 in wind 0.274/0.267/"
            "0.255/0.235/0.221 Hz at 15/30/45/60/68 m/s (reference 0.274/0.267/0.254/0.234/"
            "0.220); without the lateral DOF (P derivatives and y shapes dropped) 68.31 m/s "
            "(tests/test_modal_import.py)"),
    }


def main(wawi: Path) -> None:
    model_dir = wawi / "tests" / "models" / "model_2a"
    (OUT / "step2a_modes.json").write_text(json.dumps(modes(model_dir), indent=1) + "\n",
                                           "utf-8")
    (OUT / "step2a_bb3_derivatives.json").write_text(
        json.dumps(derivatives(model_dir), indent=1) + "\n", "utf-8")


if __name__ == "__main__":
    main(Path(sys.argv[1]))
