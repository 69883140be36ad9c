"""Do no harm: a controller judged against each bridge's own open loop.

The verdict must be able to fail: the same fixed compensator with its sign reversed drives the
flaps the wrong way and lowers the Humber critical speed below the open-loop one (flutter
68.85 m/s -> 57.33 m/s on 8 modes); the check flags it as harm. The designed sign lifts it
(88.12 m/s, closed/open 1.28). The summary's counting rules are tested on hand-made rows: an
unverified crossing is never a pass.
"""

from __future__ import annotations

import json
import re

import numpy as np
import pytest

from bridgeflap.design.assessment.harm import HarmResult, do_no_harm, harm_row
from bridgeflap.design.cli.main import main
from bridgeflap.model.aeroelastic.control import Compensator, Controller
from bridgeflap.model.aeroelastic.controller_file import save_controller
from bridgeflap.model.structure.loader import load_bridge

#: K(s) of the default card (`bridgeflap optimise`, built-in b = 14.25 m Humber, 3 m flaps,
#: 18 placed pairs; run 2026-12-03 after the model updating): a fixed, designed
#: compensator, so the test needs no optimisation
K = Compensator(-1.0520215923792988, 0.724204088492299, -4.9906722869878095,
                0.24572479364985136, 0.19628837741003988)
WRONG = Compensator(-K.b2, -K.b1, -K.b0, K.a2, K.a1)
POSITIONS = tuple(56.4 * i for i in range(-12, 13) if abs(i) >= 4)
U = np.arange(0.0, 127.5 + 1e-9, 0.5)


def _c(k):
    return Controller(k, POSITIONS, 56.4, flap_chord_m=3.0)


@pytest.fixture(scope="module")
def humber():
    return load_bridge("humber")


def test_a_controller_that_lowers_the_critical_speed_is_flagged(humber):
    bad = harm_row(humber, _c(WRONG), U, 8, 85.0)
    assert bad["resolved"] and bad["harmed"]
    assert bad["closed_loop_critical_speed_m_s"] < bad["open_loop_critical_speed_m_s"]
    assert bad["closed_over_open"] < 1.0 and not bad["stable_to_design_speed"]
    good = harm_row(humber, _c(K), U, 8, 85.0)
    assert good["resolved"] and not good["harmed"]
    # 1.2: the design lifts it 28 % on 8 modes (88.12 / 68.85 m/s, measured)
    assert good["closed_over_open"] > 1.2 and good["stable_to_design_speed"]
    # both loops of one row share the open loop: the same bridge, grid and mode count
    assert bad["open_loop_critical_speed_m_s"] == good["open_loop_critical_speed_m_s"]


def _row(ol, cl, resolved=True, stable=False):
    return {"open_loop_critical_speed_m_s": ol, "closed_loop_critical_speed_m_s": cl,
            "closed_over_open": None if cl is None or ol is None else cl / ol,
            # as design.assessment.harm.harm_row: harm only on a resolved row
            "harmed": bool(resolved and cl is not None and ol is not None and cl < ol),
            "resolved": resolved, "stable_to_design_speed": stable}


def test_summary_counts_unresolved_apart():
    rows = (_row(70.0, 90.0, stable=True), _row(70.0, 60.0), _row(70.0, 50.0, resolved=False))
    s = HarmResult("humber", 3, 8, 85.0, 127.5, 11, {}, rows).summary()
    assert s["fraction_harmed"] == pytest.approx(1 / 3)
    assert s["harmed_variants"] == [1] and s["unresolved_variants"] == 1
    # the worst ratio is over resolved rows only: the unresolved 50/70 is not a number to trust
    assert s["worst_closed_over_open"] == pytest.approx(60 / 70) and s["worst_variant"] == 1
    # a harm outranks "unresolved": a harmed variant is never hidden behind another's
    # unverified crossing; without the harmed row the block is unresolved, not no_harm
    assert s["status"] == "harm" and s["harmed_count"] == 1
    s2 = HarmResult("humber", 2, 8, 85.0, 127.5, 11, {}, rows[::2]).summary()
    assert s2["status"] == "unresolved"
    s3 = HarmResult("humber", 1, 8, 85.0, 127.5, 11, {}, rows[:1]).summary()
    assert s3["status"] == "no_harm"
    assert s["fraction_stable_to_design_speed"] == pytest.approx(1 / 3)
    json.dumps(s, allow_nan=False)


def test_do_no_harm_serial_equals_pooled(humber):
    """Two fresh variants in one process and in two: the same rows (same inputs, same code)."""
    lines = []
    a = do_no_harm(_c(K), humber, count=2, n_modes=6, speeds=U, progress=lines.append)
    b = do_no_harm(_c(K), humber, count=2, n_modes=6, speeds=U, workers=2)
    assert a.rows == b.rows
    # the progress lines count the variants and say the time taken (the time left before the
    # end: model/progress.py)
    counts = [ln for ln in lines if ln.startswith("do no harm: ") and "/2 variants" in ln]
    assert counts[0].startswith("do no harm: 1/2 variants (") and "left)" in counts[0]
    assert re.fullmatch(r"do no harm: 2/2 variants \(\d+ s\)", counts[-1])
    # the variants differ from each other and from the nominal bridge
    assert a.rows[0]["deck.gj_nm2"] != a.rows[1]["deck.gj_nm2"]


def test_cli_robustness_exit_and_table(tmp_path, capsys):
    path = save_controller(_c(WRONG), tmp_path / "controller.toml")
    out = tmp_path / "table.csv"
    rc = main(["robustness", "--controller", str(path), "--samples", "2", "--modes", "6",
               "--workers", "1", "--out", str(out), "--json"])
    s = json.loads(capsys.readouterr().out)
    assert rc == 1 and s["status"] == "harm" and s["fraction_harmed"] > 0
    assert out.read_text().count("\n") == 3  # header and two variants
    assert main(["robustness", "--controller", str(path), "--samples", "0", "--json"]) == 2


def test_an_unverified_crossing_above_the_critical_one_does_not_hide_it():
    from bridgeflap.design.assessment.harm import _crit

    base = {"flutter_status": "converged", "critical_speed_m_s": 102.3,
            "critical_mechanism": "flutter"}
    # the default design's closed-loop divergence: unverified, its bracket above the flutter
    above = base | {"divergence_status": "unverified_crossing",
                    "divergence_bracket_m_s": [110.0, 110.5]}
    assert _crit(above) == (102.3, "flutter", True)
    below = above | {"divergence_bracket_m_s": [90.0, 90.5]}  # might come first: unknown
    assert _crit(below)[2] is False
    none = {"flutter_status": "no_crossing_in_range", "divergence_status": "bracket_failed",
            "critical_speed_m_s": None}
    assert _crit(none) == (float("inf"), "none", False)
    clean = {"flutter_status": "no_crossing_in_range",
             "divergence_status": "no_crossing_in_range", "critical_speed_m_s": None}
    assert _crit(clean) == (float("inf"), "none", True)


@pytest.mark.parametrize("kwargs,field", [
    ({"count": 100_001}, "count"), ({"count": 0}, "count"),
    ({"scheduler": ""}, "scheduler"), ({"scheduler": 8786}, "scheduler")])
def test_do_no_harm_bad_arguments_one_line(humber, kwargs, field):
    """Refused before any work: the field named, one line."""
    from bridgeflap.model.errors import BridgeflapInputError

    lines = []
    with pytest.raises(BridgeflapInputError) as err:
        do_no_harm(_c(K), humber, **{"count": 2, **kwargs}, progress=lines.append)
    assert err.value.field == field and "\n" not in str(err.value)
    assert lines == []


def test_the_validation_bound_is_the_checks_bound():
    """``bridgeflap optimise --check-samples`` and ``accept(samples=)`` accept what the
    do-no-harm check itself accepts, so a run never fails on its count after the design."""
    from bridgeflap.design.assessment.accept import MAX_SAMPLES
    from bridgeflap.design.assessment.harm import MAX_VARIANTS

    assert MAX_SAMPLES == MAX_VARIANTS


@pytest.mark.slow
def test_do_no_harm_on_a_local_dask_cluster_equals_the_pool(humber):
    """Each variant is one task wherever it runs: a local Dask cluster gives the rows of the
    process pool (the same inputs, the same code; a cluster start costs ~5 s)."""
    a = do_no_harm(_c(K), humber, count=3, n_modes=6, speeds=U, workers=2)
    lines = []
    b = do_no_harm(_c(K), humber, count=3, n_modes=6, speeds=U, workers=2, scheduler="local",
                   progress=lines.append)
    assert a.rows == b.rows
    assert "on the Dask scheduler local" in lines[0]


@pytest.mark.slow
def test_cli_robustness_unreachable_scheduler(tmp_path, capsys):
    """An address nothing answers on: exit 2, one line naming --scheduler, nothing before it
    (the connection is made before the first progress line)."""
    path = save_controller(_c(K), tmp_path / "controller.toml")
    rc = main(["robustness", "--controller", str(path), "--samples", "2", "--modes", "6",
               "--scheduler", "tcp://127.0.0.1:9", "--json"])
    cap = capsys.readouterr()
    assert rc == 2 and cap.out == ""
    err = [ln for ln in cap.err.splitlines() if ln.strip()]
    assert len(err) == 1 and "scheduler" in err[0]
