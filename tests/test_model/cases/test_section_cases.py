"""bridgeflap.model.cases.section_cases.section_system: the one builder of the named section cases.

The benchmarks (bench/sweep_cases.py) and the tests (tests/test_hopf.py) build the IABSE
sections through it; it must be the system that :func:`section_case_flutter` analyses.
"""

from __future__ import annotations

import numpy as np
import pytest

from bridgeflap.model.cases.section_cases import (
    SECTION_CASES,
    case_system,
    default_speeds,
    load_section_case,
    section_system,
)
from bridgeflap.model.errors import BridgeflapInputError


@pytest.mark.parametrize("name", SECTION_CASES)
def test_section_system_is_the_case_system(name):
    system, speeds = section_system(name)
    case = load_section_case(name)
    ref, fit = case_system(case)
    assert np.array_equal(speeds, default_speeds(case))
    # the same construction twice: bit-identical matrices
    for a in ("A0", "A1", "A2"):
        assert np.array_equal(getattr(system, a), getattr(ref, a)), a
    # structure (2 n) and the fit's lag states, one set per aerodynamic DOF (2, or 3 with the
    # lateral): the default fit of case_fit
    n_dof = 2 if case.phi_p is None else 3
    assert system.n_states == 2 * case.basis.n + fit.summary()["n_lags"] * n_dof


def test_section_system_unknown_name_names_the_field():
    with pytest.raises(BridgeflapInputError, match="bridge"):
        section_system("iabse-9z")
