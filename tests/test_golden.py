"""Golden numbers: every CLI number recorded before the issue-10 redesign is reproduced.

Tolerance 1e-9 relative (plus a 1e-12 absolute floor for round-off-sized residuals): the
redesign moves code, not physics, so only floating-point reassociation may change a number; a
dense eig of a 96-state matrix reproduces to ~1e-13 relative under reassociation, and the
Brent/Ipopt stopping tests (1e-3 m/s, 1e-8) are met at the same iterate when the matrices agree
to that level. A deliberate fix re-records the case (``cd tests && python -m golden.record NAME``)
and names the changed numbers in its commit.
"""

from __future__ import annotations

import json

import pytest
from golden.cases import CASES, HERE, compare, run_case, strip_volatile

RTOL = 1e-9


@pytest.mark.parametrize(
    "name,argv",
    [pytest.param(n, a, marks=pytest.mark.slow) if slow else pytest.param(n, a)
     for n, a, slow in CASES],
    ids=[c[0] for c in CASES],
)
def test_golden(name, argv, tmp_path):
    golden = json.loads((HERE / f"{name}.json").read_text())
    new = json.loads(json.dumps(strip_volatile(run_case(name, argv, tmp_path))))
    diffs = compare(golden, new, RTOL)
    assert not diffs, f"{name}: {len(diffs)} differences, first: " + "; ".join(diffs[:8])
