"""The fast p-k (model/stability/pk_kernel.py, first-crossing march) against the reference p-k.

The reference is ``pk_sweep(..., full_grid=True)``: every branch over the whole grid with the
fixed-point k iteration on the frozen system's own matrices. Tolerances:

* kernel matrices: 1e-13 relative to the largest entry (the same sums in another order, and
  C(k) from J/Y instead of hankel2, 2e-15 relative: a few hundred round-offs of headroom);
* flutter speed: 1e-4 m/s (the required accuracy). Both paths refine by Brent from the same
  grid bracket; their branch values differ by the k-iteration tolerance (1e-10 relative), so
  Brent's iterates agree to ~1e-8 m/s (measured: at most 3e-10 m/s on these cases);
* frequency 1e-6 Hz and the marched branches 1e-8 relative, for the same reason.
"""

from __future__ import annotations

import numpy as np
import pytest

from bridgeflap.model.aero.derivatives import flat_plate, tabulated
from bridgeflap.model.aero.theodorsen import theodorsen, theodorsen_scalar
from bridgeflap.model.aeroelastic.derivative_system import derivative_system
from bridgeflap.model.aeroelastic.statespace import build
from bridgeflap.model.cases.section import section_basis
from bridgeflap.model.cases.section_cases import load_section_case, section_system
from bridgeflap.model.stability import pk_kernel
from bridgeflap.model.stability import sweeps as stability
from bridgeflap.model.stability.tracking import continue_adaptive

SPEED_M_S = 1e-4
FREQ_HZ = 1e-6
BRANCH_REL = 1e-8


def _assert_same(fast, ref):
    f, r = fast.flutter, ref.flutter
    assert f.status == r.status
    assert f.label == r.label and f.branch == r.branch
    assert f.bracket == r.bracket
    if r.status == stability.CONVERGED:
        assert f.speed == pytest.approx(r.speed, abs=SPEED_M_S)
        assert f.frequency_hz == pytest.approx(r.frequency_hz, abs=FREQ_HZ)
    m = fast.speeds.size
    np.testing.assert_array_equal(fast.speeds, ref.speeds[:m])
    # each branch up to its first unconverged point in either path: past a forced step (a
    # branch that ends, e.g. the 1.1a heave pair turning real at 75 m/s) the continuation
    # lands on whichever root the last iterate was nearest (the reference picked the conjugate
    # of the pitch branch there, the fast path the pitch branch), which is not reproducible
    both = fast.converged & ref.converged[:, :m]
    upto = np.cumprod(both, axis=1).astype(bool)
    assert upto[fast.flutter.branch if fast.flutter.branch >= 0 else 0].all() or \
        fast.flutter.status != stability.CONVERGED
    np.testing.assert_allclose(fast.branches[upto], ref.branches[:, :m][upto], rtol=BRANCH_REL)


def test_scalar_theodorsen_equals_theodorsen():
    k = np.r_[0.0, 1e-250, 1e-12, np.geomspace(1e-6, 1e6, 400), np.inf]
    exact = theodorsen(k)
    fast = np.array([theodorsen_scalar(float(x)) for x in k])
    np.testing.assert_allclose(fast, exact, rtol=1e-14, atol=0)


def _kernel_error(frozen, reference_matrix):
    ker = pk_kernel.kernel_for(frozen)
    err = 0.0
    for U in (5.0, 40.0, 90.0):
        ker.set_speed(U)
        for kr in (0.0, 0.02, 0.1, 0.35, 1.0, 3.0):
            ref = reference_matrix(U, kr)
            err = max(err, np.abs(ker.matrix(kr) - ref).max() / np.abs(ref).max())
            lam, lam_ref = ker.eigvals(kr), np.linalg.eigvals(ref)
            # every eigenvalue of the kernel is one of the reference's (geev of the transpose,
            # 1e-9 of the spectral radius for the conditioning of the non-normal matrices)
            gap = np.abs(lam[:, None] - lam_ref[None, :]).min(axis=1)
            assert gap.max() <= 1e-9 * np.abs(lam_ref).max()
    return err


def test_theodorsen_kernel_reproduces_the_frozen_matrix():
    basis = section_basis(7660.0, 3.75e5, 0.117, 0.311, 11.0, 0.005)
    fr = build(basis, 11.0, 1.225).frozen()
    assert _kernel_error(fr, lambda U, kr: fr.matrix(U, theodorsen(kr) if kr > 0 else 1.0)) \
        < 1e-13


@pytest.mark.parametrize("name", ["iabse-1.1a", "iabse-1.1c"])
def test_derivative_kernel_reproduces_matrix_at_k(name):
    system, _ = section_system(name)
    fr = system.frozen()
    assert _kernel_error(fr, fr.matrix_at_k) < 1e-13


def test_derivative_kernel_on_a_scanlan_table():
    K = np.geomspace(0.05, 3.0, 40)
    exact = flat_plate(31.0)
    table = tabulated(K, {k: exact.values(K)[k] for k in ("H1", "H2", "H3", "H4", "A1", "A2",
                                                         "A3", "A4")}, 31.0)
    case = load_section_case("iabse-1.1a")
    fr = derivative_system(case.basis, table, case.air_density).frozen()
    assert pk_kernel.kernel_for(fr)._qn.__name__ == "table"
    assert _kernel_error(fr, fr.matrix_at_k) < 1e-13  # end values held outside the table too


@pytest.mark.parametrize("name, grid", [
    # 1.1a on 0:90:0.5 (the fold of its heave branch at 75 m/s and the crossing at 77.48 m/s;
    # the reference past flutter is what makes its CLI grid slow, that one is the slow test)
    ("iabse-1.1a", np.arange(0.0, 90.0 + 1e-9, 0.5)), ("iabse-1.1c", None),
    pytest.param("iabse-1.1a", None, marks=pytest.mark.slow)])
def test_fast_pk_equals_the_reference_on_the_cli_grid(name, grid):
    system, speeds = section_system(name)
    speeds = speeds if grid is None else grid
    fast = stability.pk_sweep(system, speeds)
    ref = stability.pk_sweep(system, speeds, full_grid=True)
    assert ref.flutter.status == stability.CONVERGED
    _assert_same(fast, ref)
    # the march stopped at the grid speed above the crossing
    assert fast.speeds[-1] == fast.flutter.bracket[1] < speeds[-1]
    assert ref.speeds.size == speeds.size - 1  # U = 0 is skipped


def test_fast_pk_statuses_without_a_crossing_and_unstable_at_first():
    system, _ = section_system("iabse-1.1a")
    below = np.linspace(0.0, 60.0, 31)  # flutter at 77.48 m/s
    fast, ref = stability.pk_sweep(system, below), stability.pk_sweep(system, below, full_grid=True)
    assert fast.flutter.status == ref.flutter.status == stability.NO_CROSSING
    assert fast.branches.shape == ref.branches.shape
    _assert_same(fast, ref)
    above = np.linspace(80.0, 90.0, 6)
    fast = stability.pk_sweep(system, above)
    ref = stability.pk_sweep(system, above, full_grid=True)
    assert fast.flutter.status == ref.flutter.status == stability.UNSTABLE_AT_FIRST


def test_fast_pk_on_a_coarse_grid_from_zero():
    # 0:400:50: the crossing lies in the second interval; sub-steps keep the branches apart
    system, _ = section_system("iabse-1.1a")
    speeds = np.arange(0.0, 400.0 + 1e-9, 50.0)
    fast = stability.pk_sweep(system, speeds)
    ref = stability.pk_sweep(system, speeds, full_grid=True)
    assert ref.flutter.status == stability.CONVERGED
    _assert_same(fast, ref)


@pytest.mark.slow
@pytest.mark.parametrize("name, modes, grid", [
    ("iabse-2a", 30, (0.0, 100.0, 0.5)), ("iabse-2a:bb3", 30, (0.0, 100.0, 0.5)),
    ("humber", 12, (0.0, 85.0, 0.5))])
def test_fast_pk_equals_the_reference_on_bridges(name, modes, grid):
    from bridgeflap.model.analysis import bridge_system
    from bridgeflap.model.structure.loader import load_bridge

    _, system = bridge_system(load_bridge(name), modes)
    lo, hi, step = grid
    speeds = np.arange(lo, hi + 1e-9, step)
    fast = stability.pk_sweep(system, speeds)
    ref = stability.pk_sweep(system, speeds, full_grid=True)
    assert ref.flutter.status == stability.CONVERGED
    _assert_same(fast, ref)


def test_continue_adaptive_halves_and_counts_forced_steps():
    calls = []

    def step(t, pred):  # "good" only for steps of at most 0.25 from the last accepted speed
        calls.append(t)
        good = t - (accepted[-1] if accepted else 0.0) <= 0.25 + 1e-12
        if good:
            accepted.append(t)
        return 2.0 * t, good

    accepted = []
    y, s, forced = continue_adaptive(step, 0.0, 0.0, 2.0, 1.0, halvings=4)
    assert (y, s, forced) == (2.0, 2.0, 0)
    assert accepted == [0.25, 0.5, 0.75, 1.0]
    # no halving allowed (a spent budget): every step is accepted as it is, and counted
    accepted = []
    y, s, forced = continue_adaptive(step, 0.0, 0.0, 2.0, 1.0, halvings=4,
                                     may_halve=lambda: False)
    assert (y, forced) == (2.0, 1)


def test_branch_memory_extrapolates_a_cubic_frequency():
    mem = pk_kernel.BranchMemory()
    for U in (10.0, 10.5, 11.0, 11.5):
        mem.record(U, (1.0 + 0.01 * U ** 3) / U, None)  # k U is a cubic in U
    assert mem.guess(12.0, (1.0 + 0.01 * 12.0 ** 3) / 12.0 * 1.001) == pytest.approx(
        (1.0 + 0.01 * 12.0 ** 3) / 12.0, rel=1e-12)
    assert mem.guess(12.0, 1.0) == 1.0  # disagrees with the prediction by more than 1 %
    assert mem.guess(20.0, 1.45) == 1.45  # too far from the nodes


def test_derivative_kernel_flat_plate_with_a_lateral_dof():
    case = load_section_case("iabse-1.1c")  # heave, pitch and lateral
    fr = derivative_system(case.basis, flat_plate(case.derivatives.chord_m), case.air_density,
                           phi_p=case.phi_p).frozen()
    assert fr.n_dof == 3 and pk_kernel.kernel_for(fr)._qn.__name__ == "flat"
    assert _kernel_error(fr, fr.matrix_at_k) < 1e-13
