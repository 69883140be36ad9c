"""The text output never prints "nan m/s" for a limit that was not found."""

import math

import pytest

from bridgeflap.design.cli.main import main
from bridgeflap.design.control.review.checks import limits_text as _limits_text
from bridgeflap.design.io.text import number_text, speed_text


@pytest.mark.parametrize("missing", [None, math.nan])
def test_missing_numbers_are_named_not_nan(missing):
    assert speed_text(missing) == "none on the grid"
    assert speed_text(missing, 3, none="x") == "x"
    assert number_text(missing, ".4f", " Hz") == "-"
    assert speed_text(70.8, 3) == "70.800 m/s"
    assert number_text(0.19234, ".4f", " Hz") == "0.1923 Hz"


def test_closed_loop_limits_line_without_divergence():
    # a closed loop whose divergence is not found below the searched speed (None in the
    # summary): the design's log line names it instead of failing on the format (which
    # would have recorded the limits as failed)
    lim = {"flutter_speed_m_s": 95.92, "flutter_status": "converged",
           "divergence_speed_m_s": None, "divergence_status": "no_crossing_in_range",
           "divergence_static_speed_m_s": math.nan, "governing_speed_m_s": 95.92,
           "governing_mechanism": "flutter", "searched_to_m_s": 170.0}
    line = _limits_text(lim)
    assert "nan" not in line.lower()
    assert "divergence none below 170 m/s" in line
    assert "flutter 95.92 m/s" in line
    # a crossing that failed verification is not "none": its speed is not determined
    line = _limits_text({**lim, "divergence_status": "unverified_crossing"})
    assert "divergence not determined (unverified_crossing" in line and "nan" not in line


def test_section_and_flutter_text_without_crossings(capsys):
    # a section and a bridge swept below any instability: both limits are "none on the
    # grid" in the text output (not "nan m/s" / "at nan Hz"), exit 0
    argv = ["section", "--mass", "22740", "--inertia", "2470000", "--f-heave", "0.1",
            "--f-torsion", "0.3", "--half-chord", "14.25", "--speeds", "0:20:1"]
    for aero in ("exact", "rfa4"):
        assert main([*argv, "--aero", aero]) == 0
        out = capsys.readouterr().out
        assert "nan" not in out.lower() and "none on the grid" in out
    assert main(["flutter", "--speeds", "0:30:1", "--modes", "8"]) == 0
    out = capsys.readouterr().out
    assert "nan" not in out.lower() and "flutter:    none on the grid" in out
