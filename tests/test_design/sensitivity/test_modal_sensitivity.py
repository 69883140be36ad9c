"""Sensitivities of flutter and divergence speeds to modal data (design/sensitivity/modal.py).

Kinds of check: (a) analytic: the flat-plate torsional divergence of iabse-2a is the single-mode
formula ``U_D = sqrt(2 M_j omega_j^2 / (rho B^2 C_M' int phi_a^2))`` on TS1 (docs/great_belt.md),
so ``dU_D/df = U_D / f`` and ``dU_D/dM = U_D / (2 M)`` exactly; (d) the implicit-function
derivatives against central finite differences of the re-swept speeds, on the Theodorsen state
space (iabse-2a) and on the flutter-derivative Roger state space (iabse-2a:bb3).

Tolerances. The IFT uses a central difference of A (relative step 1e-4, truncation 1e-8) and is
otherwise exact; the check is a central difference of U (relative step 1e-3: truncation
~1e-6 relative; the crossings are refined to 1e-7 m/s, i.e. 1e-7 / (2e-3 p) in the quotient,
below 1e-6 relative for these derivatives). 1e-5 relative covers both with a margin of 10
(measured: at most 4e-7). Derivatives that vanish (damping does not move a static divergence)
are compared in absolute terms against the scale of the largest one.
"""

from __future__ import annotations

import numpy as np
import pytest

from bridgeflap.design.sensitivity.local import local_sensitivity
from bridgeflap.model.errors import BridgeflapInputError
from bridgeflap.model.structure.loader import load_bridge

SPEEDS = np.arange(0.0, 100.01, 1.0)
FLAT = ["mode.TS1.frequency_hz", "mode.TS1.damping_ratio", "mode.TS1.generalised_mass",
        "mode.VS1.frequency_hz", "mode.VS1.generalised_mass"]


@pytest.fixture(scope="module")
def flat():
    return local_sensitivity(load_bridge("iabse-2a"), FLAT, speeds=SPEEDS, n_modes=9)


def test_divergence_derivatives_are_the_single_mode_formula(flat):
    UD = flat.divergence_speed_m_s
    rows = {r["parameter"]: r for r in flat.rows}
    f = rows["mode.TS1.frequency_hz"]
    m = rows["mode.TS1.generalised_mass"]
    assert f["d_divergence_speed"] == pytest.approx(UD / f["value"], rel=1e-6)
    assert m["d_divergence_speed"] == pytest.approx(UD / (2 * m["value"]), rel=1e-6)
    assert f["relative_d_divergence_speed"] == pytest.approx(1.0, rel=1e-6)


@pytest.mark.parametrize("q", ["flutter", "divergence"])
def test_ift_matches_central_differences_theodorsen(flat, q):
    scale = max(abs(r[f"d_{q}_speed"] * r["value"]) for r in flat.rows)
    for r in flat.rows:
        assert r[f"{q}_status"] == "ok" and r[f"{q}_fd_same_branch"]
        d, fd = r[f"d_{q}_speed"], r[f"d_{q}_speed_fd"]
        assert abs(d - fd) * r["value"] <= 1e-5 * max(abs(fd * r["value"]), 1e-3 * scale), \
            r["parameter"]


def test_ift_matches_central_differences_derivative_loads():
    params = ["mode.TS1.frequency_hz", "mode.TS1.damping_ratio", "mode.VS1.generalised_mass"]
    res = local_sensitivity(load_bridge("iabse-2a:bb3"), params, speeds=np.arange(0, 90.1, 1.0),
                            n_modes=12)
    assert res.flutter_status == "converged"
    for r in res.rows:
        assert r["flutter_fd_same_branch"]
        assert r["d_flutter_speed"] == pytest.approx(r["d_flutter_speed_fd"], rel=1e-5)
    # TS1's frequency carries the flutter speed almost in proportion (p/U dU/dp ~ 1.1)
    assert res.rows[0]["relative_d_flutter_speed"] == pytest.approx(1.13, abs=0.05)


@pytest.mark.parametrize("params", [["mode.XX9.frequency_hz"], ["mode.TS1.frequency_hz",
                                                                  "deck.half_chord_m"]])
def test_bad_modal_parameters_name_the_field(params):
    with pytest.raises(BridgeflapInputError) as e:
        local_sensitivity(load_bridge("iabse-2a"), params, speeds=SPEEDS, n_modes=9, check=False)
    assert e.value.field == "parameters"
