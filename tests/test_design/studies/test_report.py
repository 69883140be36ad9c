"""The study report: report.md and report.html show the same tables, and every number in them is
the one in results/*.json (rounded as printed, nothing else)."""

import json
from dataclasses import replace
from html.parser import HTMLParser
from pathlib import Path
from types import MappingProxyType, SimpleNamespace

import pytest

from bridgeflap.design.studies.report import study_document
from bridgeflap.design.studies.study import load_study, run_study


class _Tables(HTMLParser):
    """Cell texts of every <table> of an HTML page."""

    def __init__(self):
        super().__init__()
        self.tables, self._cell = [], None

    def handle_starttag(self, tag, attrs):
        if tag == "table":
            self.tables.append([])
        elif tag == "tr":
            self.tables[-1].append([])
        elif tag in ("td", "th"):
            self._cell = ""

    def handle_endtag(self, tag):
        if tag in ("td", "th"):
            self.tables[-1][-1].append(self._cell.strip())
            self._cell = None

    def handle_data(self, data):
        if self._cell is not None:
            self._cell += data


def md_tables(text: str) -> list[list[list[str]]]:
    """Rows of cells of every pipe table (the separator row dropped)."""
    tables, cur = [], None
    for line in text.splitlines():
        if line.startswith("|"):
            if cur is None:
                cur = []
                tables.append(cur)
            cells = [c.strip() for c in line.strip().strip("|").split("|")]
            if not all(set(c) <= set(":-") for c in cells):
                cur.append(cells)
        else:
            cur = None
    return tables


def html_tables(text: str) -> list[list[list[str]]]:
    p = _Tables()
    p.feed(text)
    return p.tables


def _table(tables, header0):
    found = [t for t in tables if t[0][0] == header0]
    assert found, header0
    return {row[0]: dict(zip(found[0][0], row, strict=True)) for row in found[0][1:]}


def _close(cell: str, value: float, digits: int) -> bool:
    """``cell`` is ``value`` printed with ``digits`` decimals (half a unit of the last digit)."""
    return abs(float(cell) - value) <= 0.5 * 10.0 ** -digits + 1e-12


@pytest.fixture(scope="module")
def study(tmp_path_factory):
    cfg = load_study(quick=True)
    keep = ("modes", "flutter", "sensitivity")
    cfg = replace(cfg, analyses=tuple(a for a in cfg.analyses if a[0] in keep))
    out = tmp_path_factory.mktemp("report") / "out"
    run_study(cfg, out_dir=out)
    return out


def test_markdown_and_html_show_the_same_tables(study):
    md = md_tables((study / "report.md").read_text())
    html = (study / "report.html").read_text()
    assert md and md == html_tables(html)
    # self-contained: every figure inline, none linked
    figs = sorted((study / "figures").glob("*.png"))
    assert figs and html.count("data:image/png;base64,") == len(figs)
    assert 'src="figures/' not in html


def test_report_numbers_are_the_result_files(study):
    tables = md_tables((study / "report.md").read_text())
    res = {p.stem: json.loads(p.read_text()) for p in (study / "results").glob("*.json")}
    statuses = json.loads((study / "statuses.json").read_text())
    assert {k: v["status"] for k, v in _table(tables, "analysis").items()} == statuses
    t1 = [t for t in tables if t[0][0] == "family"][0][1:]  # Table 1 repeats labels: in order
    assert len(t1) == len(res["modes"]["table1"])
    for row, r in zip(t1, res["modes"]["table1"], strict=True):
        assert row[1] == r["table1_label"] and row[5] == r["bridgeflap_label"]
        assert _close(row[2], r["measured_hz"], 3) and _close(row[4], r["bridgeflap_hz"], 3)
        assert _close(row[6], r["difference_percent"], 1)
    fl, f = _table(tables, "quantity"), res["flutter"]
    # each number says the mode count of its model ("69.50 (16 modes)")
    n = f["modes_retained"]
    ours = {k: v["ours"].removesuffix(f" ({n} modes)") for k, v in fl.items()}
    assert all(v["ours"].endswith(f" ({n} modes)") for v in fl.values())
    assert _close(ours["flutter speed [m/s]"], f["flutter_speed_m_s"], 2)
    assert _close(ours["flutter frequency [Hz]"], f["flutter_frequency_hz"], 4)
    assert _close(ours["torsional divergence [m/s]"], f["divergence_speed_m_s"], 2)
    assert fl["flutter speed [m/s]"]["status"] == f["flutter_status"]
    sens = _table(tables, "parameter")
    d = res["sensitivity"]["derivatives"]
    assert set(sens) == set(d)
    for p, row in sens.items():
        # four significant digits ('.4g')
        assert float(row["dU_F/dp (IFT)"]) == pytest.approx(d[p]["d_flutter_speed_m_s_per_unit"],
                                                                   rel=5e-4)
        assert _close(row["(p/U_F) dU_F/dp"], d[p]["relative_d_flutter_speed"], 3)
        # the kink check's cell: '-' or the flagged speeds' one-sided slopes
        kink = row["kink: one-sided (p/U) dU/dp"]
        assert (kink == "-") is (d[p]["kink"] is False)
        if d[p]["flutter_kink"]:
            assert kink.startswith(f"UF {d[p]['relative_d_flutter_speed_minus']:+.3f}/")


def test_design_section_numbers_are_the_design_summary():
    d = {"status": "converged", "coefficients": {"b2": 0.5, "b1": -1.25, "b0": -2.5,
                                                 "a2": 0.08, "a1": 0.4},
         "flap_count": 25, "max_gain": 5.8312, "gain_limit": 15.0, "robust_margin": 0.1003,
         "robust_margin_worst_speed_m_s": 84.25, "robust_margin_at_robust_speeds": 0.1012,
         "closed_loop_stable_to_m_s": 85.0, "wall_time_s": 70.94, "elapsed_s": 84.52,
         "verification": {"modes": 16, "min_damping_ratio": 0.00531},
         "robust_T_inf_by_speed": {"10": 0.2226, "85": 9.988},
         "closed_loop_limits": {"governing_speed_m_s": 88.146, "flutter_speed_m_s": 88.146,
                                "open_loop_flutter_speed_m_s": 70.8877, "modes": 30},
         "starts": [{"start": 0, "status": "Solve_Succeeded", "iterations": 12}],
         "buffeting": {"speeds_m_s": [10.0], "open_loop_rms_vertical_m": [0.02],
                       "closed_loop_rms_vertical_m": [0.01],
                       "open_loop_rms_torsion_rad": [1e-3],
                       "closed_loop_rms_torsion_rad": [2e-3]}}
    res = SimpleNamespace(config=SimpleNamespace(name="t", bridge="humber", quick=True,
                                                 element_length_m=None),
                          statuses=MappingProxyType({"design": "converged"}),
                          results=MappingProxyType({"design": d}), elapsed_s=90.0)
    tables = md_tables(study_document(res, {}).markdown())
    q = {k: v["value"] for k, v in _table(tables, "quantity").items()}
    assert q["optimisation wall time [s]"] == "70.9"
    assert q["analysis time incl. the Fig. 5 sweeps [s]"] == "84.5"  # what the log says
    # the design model's speeds with its mode count: not the study's flutter speed (16 modes)
    assert q["open-loop flutter of the design model [m/s]"] == "70.89 (30 modes)"
    assert q["governing closed-loop limit [m/s]"].endswith(", 30 modes)")
    # the headline margin is the speed grid's, with its speed and the robust speeds' value
    assert (q["robust margin 1 / max norm(T, inf) over the speed grid"]
            == "0.1003 at 84.25 m/s (0.1012 at the robust speeds)")
    margin = _table(tables, "U [m/s]")
    assert margin["85"]["margin [-]"] == f"{1 / 9.988:.3f}"
    buf = [t for t in tables if t[0][0] == "U [m/s]"][-1]
    # vertical in mm, torsion in deg (the summary keeps m and rad)
    assert buf[0][1:3] == ["vertical, open loop [mm]", "vertical, closed loop [mm]"]
    assert buf[1] == ["10", "20.0", "10.0", "-50.0 %", "0.0573", "0.115", "+100.0 %"]
    assert _table(tables, "start")["0"]["Ipopt status"] == "Solve_Succeeded"


def test_report_file_names_are_listed_in_the_study_docstring():
    import bridgeflap.design.studies.study

    assert "report.html" in Path(bridgeflap.design.studies.study.__file__).read_text()


def test_the_usable_speed_leads_the_report_and_fig5_right_is_a_table():
    row = {"open_loop_rms_heave_m": 1.67592, "closed_loop_rms_heave_m": 0.98866,
           "open_loop_rms_twist_rad": 0.04379, "closed_loop_rms_twist_rad": 0.03061,
           "flap_rate_3sigma_deg_s": 16.74, "flap_angle_limit_deg": 20.0,
           "flap_rate_limit_deg_s": 40.0}
    rows = [{**row, "speed_m_s": 64.0, "flap_angle_3sigma_deg": 18.05,
             "within_actuator_limits": True},
            {**row, "speed_m_s": 72.0, "open_loop_rms_heave_m": None,
             "flap_angle_3sigma_deg": 32.32, "within_actuator_limits": False}]
    d = {"status": "failed_checks", "coefficients": {"b2": -0.73, "b1": -0.34, "b0": -3.71,
                                                     "a2": 0.27, "a1": 0.31},
         "usable_speed_m_s": 65.53, "usable_speed_limited_by": "flap angle 3 sigma",
         "open_loop_critical_speed_m_s": 69.5115, "linear_closed_loop_critical_speed_m_s": 87.3232,
         "acceptance": {"status": "failed", "reason": "usable speed 65.5 m/s not above the "
                                                     "open-loop critical speed 69.5 m/s"},
         "response_by_speed": rows}
    res = SimpleNamespace(config=SimpleNamespace(name="t", bridge="humber", quick=True,
                                                 element_length_m=None),
                          statuses=MappingProxyType({"design": "failed_checks"}),
                          results=MappingProxyType({"design": d}), elapsed_s=90.0)
    md = study_document(res, {}).markdown()
    paragraphs = [p for p in md.split("\n\n") if p.strip()]
    # the verdict paragraph comes right after the title and the bridge line
    assert paragraphs[2].startswith("**Usable speed 65.5 m/s** (limited by flap angle 3 sigma) "
                                    "against the open-loop critical speed 69.51 m/s; linear "
                                    "closed-loop critical speed (ideal actuators) 87.32 m/s.")
    assert "NOT usable" in paragraphs[2] and "not above the open-loop" in paragraphs[2]
    t = _table(md_tables(md), "U [m/s]")
    assert t["64"]["3σ flap angle [deg]"] == "18.1" and t["64"]["actuators"] == "within"
    assert t["72"]["actuators"] == "**beyond limit**"
    assert t["72"]["heave, open loop [m]"] == "-"      # beyond the open loop's critical speed
    assert t["64"]["twist, closed loop [deg]"] == "1.75"    # 0.03061 rad


def test_acceptance_rows_keep_the_verdict_and_its_meaning():
    # the verdict's meaning is a line without a "check: result" form (it broke the report
    # once): it becomes a row of its own
    from bridgeflap.design.assessment.acceptance import VERDICT_MEANING, acceptance_text
    from bridgeflap.design.studies.report import acceptance_rows

    rows = acceptance_rows(acceptance_text({"status": "passed", "checks": ["robustness"]}))
    assert rows[0] == ("acceptance", "passed")
    assert any(VERDICT_MEANING["passed"] in r for _, r in rows)
