"""The plant for control engineers (bridgeflap.model.aeroelastic.control_plant, ``bridgeflap
state-space
--inputs``).

(c) cross-method: the open-loop plant with flap inputs, closed in python-control with the
built-in compensator, has the eigenvalues of the package's own closed loop
(:func:`bridgeflap.model.aeroelastic.flaps.closed_loop_system`, what ``bridgeflap flutter
--controller`` sweeps).
"""

from __future__ import annotations

import json
import sys

import numpy as np
import pytest
import scipy.io
import scipy.linalg as sla

from bridgeflap import model
from bridgeflap.design.cli.main import main
from bridgeflap.model.aeroelastic.control import Compensator, Controller
from bridgeflap.model.aeroelastic.control_plant import plant_data
from bridgeflap.model.aeroelastic.flaps import closed_loop_system
from bridgeflap.model.errors import BridgeflapError

control = pytest.importorskip("control")

CTRL = Controller(Compensator(0.0, 0.1, -0.5, 0.01, 0.2), (-56.4, 0.0, 56.4), 56.4)
N_MODES = 6
SPEED = 40.0


def _clusters(lam, tol):
    """Eigenvalues grouped within ``tol`` (relative): (mean, multiplicity) per group."""
    lam = np.sort_complex(np.asarray(lam))
    groups = []
    for x in lam:
        for g in groups:
            if abs(x - g[0]) <= tol * max(1.0, abs(x)):
                g.append(x)
                break
        else:
            groups.append([x])
    return [(np.mean(g), len(g)) for g in groups]


@pytest.mark.parametrize("speed", [0.0, SPEED])
def test_python_control_loop_matches_closed_loop_eigenvalues(coarse_humber, speed):
    P = model.plant(coarse_humber, speed, inputs="both", n_modes=N_MODES, controller=CTRL)
    nf = CTRL.n_flaps
    Pf = P[[f"pitch_flap[{f}]" for f in range(nf)],
           [f"flap_te[{f}]" for f in range(nf)] + [f"flap_le[{f}]" for f in range(nf)]]
    K1 = control.ss(*CTRL.compensator.state_space())
    # beta_TE = +K alpha_f, beta_LE = -K alpha_f (model.aeroelastic.flaps drive convention)
    K = control.ss([], [], [], np.vstack([np.eye(nf), -np.eye(nf)])) * control.append(*[K1] * nf)
    closed = control.feedback(Pf, K, sign=1)
    A_ref = closed_loop_system(coarse_humber, CTRL, n_modes=N_MODES).A(speed)
    ref, got = np.linalg.eigvals(A_ref), closed.poles()
    assert got.size == ref.size
    # Every built-in eigenvalue is an eigenvalue of the python-control loop to rounding: the
    # smallest singular value of (A_pc - lam I) is ~1e-20 of ||A_pc|| (backward error; bound
    # 1e-13 leaves room for the norm of the coordinate change).
    A_pc = closed.A
    scale = np.linalg.norm(A_pc, 2)
    for lam in ref:
        assert sla.svdvals(A_pc - lam * np.eye(A_pc.shape[0]))[-1] <= 1e-13 * scale
    # And the eigenvalues themselves agree to 1e-9 (relative): repeated eigenvalues (the
    # compensator pole copied on every flap, the RFA lag poles at U = 0) are defective, so a
    # cluster is known only to ~sqrt(eps) per member but its mean to rounding: compare means
    # and multiplicities of the clusters within 1e-6.
    cr, cg = _clusters(ref, 1e-6), _clusters(got, 1e-6)
    assert [m for _, m in cr] == [m for _, m in cg]
    for (a, _), (b, _) in zip(cr, cg, strict=True):
        assert abs(a - b) <= 1e-9 * max(1.0, abs(a))


def test_gust_plant_is_the_open_loop_system(coarse_humber):
    from bridgeflap.model.analysis import bridge_system

    _, system = bridge_system(coarse_humber, N_MODES)
    p = plant_data(coarse_humber, SPEED, "gust", N_MODES, system=system)
    np.testing.assert_array_equal(p.A, system.A(SPEED))
    np.testing.assert_array_equal(p.B, system.B_gust(SPEED))
    np.testing.assert_array_equal(p.C, system.C_out)
    ns = system.basis.n_strip
    assert p.input_names[3] == "gust[3]" and p.output_names[ns + 2] == "pitch[2]"
    np.testing.assert_array_equal(p.strip_x_m, system.basis.strip_x)
    sysc = p.to_control()
    assert sysc.input_labels[3] == "gust[3]"
    json.loads(json.dumps(p.to_dict(), allow_nan=False))


def test_flap_plant_both_is_gust_plus_flaps(coarse_humber):
    both = plant_data(coarse_humber, SPEED, "both", N_MODES, flaps=4)
    flaps = plant_data(coarse_humber, SPEED, "flaps", N_MODES, flaps=4)
    ns = both.strip_x_m.size
    np.testing.assert_array_equal(both.B[:, ns:], flaps.B)
    assert flaps.input_names == tuple(f"flap_{e}[{f}]" for e in ("te", "le") for f in range(4))
    assert flaps.flap_x_m.size == 4 and flaps.output_names[-1] == "pitch_flap[3]"
    # flaps touch and cover the main span, centred on its mid-point
    np.testing.assert_allclose(flaps.flap_position_m.sum(), 0.0, atol=1e-9)


def test_to_control_without_python_control(monkeypatch, coarse_humber):
    p = plant_data(coarse_humber, 10.0, "gust", 2)
    monkeypatch.setitem(sys.modules, "control", None)
    with pytest.raises(BridgeflapError, match="python-control is not installed"):
        p.to_control()


@pytest.mark.parametrize("ext", [".npz", ".mat"])
def test_cli_state_space_flap_inputs(tmp_path, capsys, ext):
    out = tmp_path / f"p{ext}"
    assert main(["state-space", "--speed", "30", "--modes", "4", "--inputs", "flaps",
                 "--flaps", "2", "--out", str(out), "--json"]) == 0
    r = json.loads(capsys.readouterr().out)
    assert r["input_set"] == "flaps" and r["inputs"] == 4
    if ext == ".npz":
        with np.load(out) as z:   # names as unicode arrays: no pickle needed
            names = [str(s) for s in z["input_names"]]
            fx = z["flap_x_m"]
    else:
        m = scipy.io.loadmat(out)
        names = [str(c[0]) for c in m["input_names"].ravel()]  # a cell array, no padding
        fx = m["flap_x_m"].ravel()
    assert names == ["flap_te[0]", "flap_te[1]", "flap_le[0]", "flap_le[1]"]
    assert fx.size == 2
