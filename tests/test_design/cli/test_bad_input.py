"""Bad-input matrix: every ``bridgeflap`` command refuses bad input the same way.

The contract (design/cli/main.py): an input fault gives exit status 2, exactly one line
``bridgeflap: error: <field>: <reason>`` on stderr, no traceback, nothing on stdout (also with
``--json``, as tests/test_cli.py fixes), nothing written in the output location and an earlier
result there left byte-identical. An internal fault (anything that is not a
:class:`~bridgeflap.model.errors.BridgeflapError`) gives exit status 1 and one line saying it is a
bug; the traceback only with ``--debug``.

Cases run in-process through :func:`bridgeflap.design.cli.main.main` (capsys), in a folder that
holds earlier outputs of every command (``prev.*``) and is the working directory, so that a default
output location is watched too; a few run in a subprocess. Every case fails before any analysis runs
or right after the cheap modal model, so the matrix takes seconds.
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from importlib import resources
from pathlib import Path

import pytest

from bridgeflap.design.cli import main as cli
from bridgeflap.design.cli.main import COMMANDS, main

ROOT = Path(__file__).resolve().parents[3]
HUMBER = resources.files("bridgeflap.model.bridges").joinpath("humber.toml").read_text("utf-8")
SECTION = ["--mass", "12460", "--inertia", "9.56e5", "--f-heave", "0.1166",
           "--f-torsion", "0.2979", "--half-chord", "11"]


def _sub(old: str, new: str, count: int = 1) -> str:
    """humber.toml with ``old`` (a regular expression) replaced ``count`` times."""
    text, n = re.subn(old, new, HUMBER, count=count, flags=re.M)
    assert n == count, old
    return text


#: bridge files: name -> text (each one fault)
BRIDGES = {
    "added_inertia_str": _sub(r"^added_inertia = true", 'added_inertia = "false"'),
    "suspended_str": _sub(r"^suspended_deck = true", 'suspended_deck = "no"'),
    "typo_key": _sub(r"^coherence_decay =", "coherence_decy ="),
    "dup_span": _sub(r'^name = "barton"', 'name = "hessle"'),
    "gj_1e300": _sub(r"^gj_nm2 = \{ value = [0-9.e]+", "gj_nm2 = { value = 1e300"),
    "ei_nan": _sub(r"^ei_lateral_nm2 = \{ value = [0-9.e]+", "ei_lateral_nm2 = { value = nan"),
    "cable_mass_neg": _sub(r"^mass_kg_per_m = \{ value = 2388.0", "mass_kg_per_m = { value = -1"),
    "span_zero": _sub(r"^length_m = \{ value = 1410.0", "length_m = { value = 0.0"),
    "element_long": _sub(r"^element_length_m = \{ value = [0-9.]+",
                         "element_length_m = { value = 2000.0"),
    "element_tiny": _sub(r"^element_length_m = \{ value = [0-9.]+",
                         "element_length_m = { value = 0.01"),
    "chord_1e300": _sub(r"^half_chord_m = \{ value = [0-9.]+", "half_chord_m = { value = 1e300"),
    "item_y_1e300": _sub(r"^y_m = 2.25", "y_m = 1e300"),
    "int_huge": _sub(r"^area_m2 = \{ value = 0.2935", "area_m2 = { value = 1" + "0" * 400),
    "unknown_section": HUMBER + "\n[frobnicate]\nx = 1\n",
    "section_item_key": _sub(r'^kind = "plate"', 'kind = "plate"\ncolour = "red"'),
    "variant_key": _sub(r"^\[variants.box\]", '[variants.box]\n"deck.colour" = 1'),
    "value_str": _sub(r"^gj_nm2 = \{ value = [0-9.e]+", 'gj_nm2 = { value = "big"'),
    "malformed": "[deck\nmass = \n",
    # 140 m elements: 17 elements, 39 vertical and torsional modes
    "coarse": _sub(r"^element_length_m = \{ value = [0-9.]+", "element_length_m = { value = 140.0"),
}

#: other input files: name -> text
FILES = {
    "ctrl_unstable.toml": "b2 = 0.0\nb1 = 0.0\nb0 = 1.0\na2 = -1.0\na1 = 1.0\n"
                          "flap_strip_positions_m = [0.0]\nflap_width_m = 50.0\n",
    "ctrl_typo.toml": "b2 = 0.0\nb1 = 0.0\nb0 = 1.0\na2 = 0.1\na1 = 1.0\ngain_limt = 15.0\n"
                      "flap_strip_positions_m = [0.0]\nflap_width_m = 50.0\n",
    "ctrl_high_gain.toml": "b2 = 0.0\nb1 = 0.0\nb0 = 20.0\na2 = 0.1\na1 = 1.0\n"
                           "flap_strip_positions_m = [0.0]\nflap_width_m = 50.0\n"
                           "gain_limit = 15.0\n",
    "design_a2.toml": 'a2_bounds = "abc"\n',
    "design_options.toml": 'options = "abc"\n',
    "design_angle.toml": "[actuators]\nflap_angle_limit_deg = -5.0\n",
    "design_design.toml": "design = 7\n",
    "design_nmodes.toml": "[model]\nn_modes = 2.5\n",
    "design_bool.toml": 'optimise_placement = "yes"\n',
    "design_bridge.toml": 'bridge = "nosuchbridge"\n',
    "study_rfa.toml": 'name = "s"\nanalyses = ["flutter"]\n[flutter]\nrfa = "bogus"\n',
    "study_unknown_opt.toml": 'name = "s"\nanalyses = ["flutter"]\n[flutter]\nmodez = 4\n',
    "study_modes.toml": 'name = "s"\nanalyses = ["flutter"]\n[flutter]\nmodes = 100000\n',
    "study_speeds.toml": 'name = "s"\nanalyses = ["flutter"]\n[flutter]\nspeeds = "0:inf:1"\n',
    "study_speeds_type.toml": 'name = "s"\nanalyses = ["flutter"]\n[flutter]\nspeeds = {a = 1}\n',
    "study_design.toml": 'name = "s"\nanalyses = ["design"]\n[design]\na2_bounds = "abc"\n',
    "study_design7.toml": 'name = "s"\nanalyses = ["design"]\ndesign = 7\n',
    "study_design_key.toml": 'name = "s"\nanalyses = ["design"]\n[design]\nfrobnicate = 1\n',
    "study_buffeting.toml": 'name = "s"\nanalyses = ["buffeting"]\n[buffeting]\nmc_seed = -1\n',
    "study_spectrum.toml": 'name = "s"\nanalyses = ["buffeting"]\n[buffeting]\n'
                           'spectrum = "bogus"\n',
    "study_bool.toml": 'name = "s"\nanalyses = ["sensitivity"]\n[sensitivity]\ncheck = "no"\n',
    "study_fractions.toml": 'name = "s"\nanalyses = ["erection"]\n[erection]\n'
                            'fractions = "0:2:0.5"\n',
    "study_side.toml": 'name = "s"\nanalyses = ["erection"]\n[erection]\nside_spans = "x"\n',
    "study_bridge.toml": 'name = "s"\nbridge = "bad_gj_1e300.toml"\nanalyses = ["flutter"]\n',
    "study_ok.toml": 'name = "s"\nanalyses = ["modes"]\n',
    "doe_ok.toml": 'name = "d"\nanalysis = "modes"\ndesign = { levels = 2 }\n[parameters]\n'
                   '"deck.gj_nm2" = [3.0e11, 4.5e11]\n',
    "doe_rfa.toml": 'name = "d"\n[options]\nrfa = "bogus"\n[parameters]\n'
                    '"deck.gj_nm2" = [3.0e11, 4.5e11]\n',
    "doe_options.toml": 'name = "d"\noptions = "abc"\n[parameters]\n'
                        '"deck.gj_nm2" = [3.0e11, 4.5e11]\n',
    "doe_design.toml": 'name = "d"\ndesign = 7\n[parameters]\n"deck.gj_nm2" = [3.0e11, 4.5e11]\n',
    "doe_quick.toml": 'name = "d"\n[quick]\noptions = "abc"\n[parameters]\n'
                      '"deck.gj_nm2" = [3.0e11, 4.5e11]\n',
    "doe_levels.toml": 'name = "d"\ndesign = { levels = 100000 }\n[parameters]\n'
                       '"deck.gj_nm2" = [3.0e11, 4.5e11]\n"deck.mass_kg_per_m" = [1e4, 2e4]\n',
    "doe_param.toml": 'name = "d"\n[parameters]\n"deck.colour" = [1, 2]\n',
    "doe_range.toml": 'name = "d"\n[parameters]\n"deck.gj_nm2" = [4.5e11, 3.0e11]\n',
    "doe_modes.toml": 'name = "d"\n[options]\nmodes = 0\n[parameters]\n'
                      '"deck.gj_nm2" = [3.0e11, 4.5e11]\n',
}

#: earlier outputs in the working folder, which no failed run may touch
PREVIOUS = {"prev.npz": b"previous state space", "prev.png": b"previous figure",
            "prev_out/controller.toml": b"previous controller",
            "prev_study/report.md": b"previous study", "prev_doe/table.csv": b"previous table"}


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    """The working folder: bridge and input files, earlier outputs, a binary file."""
    d = tmp_path_factory.mktemp("bad_input")
    for name, text in BRIDGES.items():
        (d / f"bad_{name}.toml").write_text(text, encoding="utf-8")
    for name, text in FILES.items():
        (d / name).write_text(text, encoding="utf-8")
    for name, data in PREVIOUS.items():
        (d / name).parent.mkdir(exist_ok=True)
        (d / name).write_bytes(data)
    (d / "binary.toml").write_bytes(b"\xff\xfe\x00garbage")
    (d / "adir.toml").mkdir()
    return d


def _snapshot(folder: Path) -> dict:
    """Every file and folder below ``folder`` with its bytes and mtime (temp files too)."""
    return {p.relative_to(folder): (p.stat().st_mtime_ns, p.read_bytes() if p.is_file() else None)
            for p in folder.rglob("*")}


B = "--bridge"
#: (id, argv, field named on stderr); ``{d}`` is the working folder
CASES = [
    # ---- modes
    ("modes-count-0", ["modes", "--count", "0"], "count"),
    ("modes-count-huge", ["modes", "--count", "100000"], "count"),
    ("modes-count-str", ["modes", "--count", "ten"], "count"),
    ("modes-erection-nan", ["modes", "--erection", "nan"], "erected_fraction"),
    ("modes-erection-neg", ["modes", "--erection=-0.5"], "erected_fraction"),
    ("modes-bridge-dir", ["modes", B, "{d}/adir.toml"], "bridge"),
    ("modes-bridge-binary", ["modes", B, "{d}/binary.toml"], "bridge"),
    ("modes-bridge-nosuffix", ["modes", B, "{d}/prev.npz"], "bridge"),
    ("modes-plot-suffix", ["modes", "--plot", "{d}/fig.txt"], "plot"),
    ("modes-plot-under-file", ["modes", "--plot", "{d}/prev.npz/fig.png"], "plot"),
    ("modes-unknown-option", ["modes", "--frobnicate"], "arguments"),
    # ---- bridge files (through flutter, the common path)
    ("bridge-added-inertia-str", ["flutter", B, "{d}/bad_added_inertia_str.toml"],
     "aero.added_inertia"),
    ("bridge-suspended-str", ["flutter", B, "{d}/bad_suspended_str.toml"],
     "spans.hessle.suspended_deck"),
    ("bridge-typo-key", ["flutter", B, "{d}/bad_typo_key.toml"], "aero.coherence_decy"),
    ("bridge-duplicate-span", ["flutter", B, "{d}/bad_dup_span.toml"], "spans.hessle"),
    ("bridge-gj-1e300", ["flutter", B, "{d}/bad_gj_1e300.toml"], "deck.gj_nm2"),
    ("bridge-ei-nan", ["flutter", B, "{d}/bad_ei_nan.toml"], "deck.ei_lateral_nm2"),
    ("bridge-cable-mass-neg", ["flutter", B, "{d}/bad_cable_mass_neg.toml"],
     "cable.mass_kg_per_m"),
    ("bridge-span-zero", ["flutter", B, "{d}/bad_span_zero.toml"], "spans.main.length_m"),
    ("bridge-element-long", ["flutter", B, "{d}/bad_element_long.toml"],
     "mesh.element_length_m"),
    ("bridge-element-tiny", ["flutter", B, "{d}/bad_element_tiny.toml"],
     "mesh.element_length_m"),
    ("bridge-chord-1e300", ["flutter", B, "{d}/bad_chord_1e300.toml"], "deck.half_chord_m"),
    ("bridge-item-y-1e300", ["flutter", B, "{d}/bad_item_y_1e300.toml"],
     "deck_section.deck_plate.y_m"),
    ("bridge-int-huge", ["flutter", B, "{d}/bad_int_huge.toml"], "cable.area_m2"),
    ("bridge-unknown-section", ["flutter", B, "{d}/bad_unknown_section.toml"], "frobnicate"),
    ("bridge-section-item-key", ["flutter", B, "{d}/bad_section_item_key.toml"], "colour"),
    ("bridge-variant-key", ["flutter", B, "{d}/bad_variant_key.toml"], "deck.colour"),
    ("bridge-value-str", ["flutter", B, "{d}/bad_value_str.toml"], "deck.gj_nm2"),
    ("bridge-malformed", ["flutter", B, "{d}/bad_malformed.toml"], "bridge"),
    ("bridge-unknown-variant", ["flutter", B, "humber:nosuch"], "bridge"),
    # ---- frequency-ratio
    ("ratio-fractions-inf", ["frequency-ratio", "--fractions", "0.1:inf:0.1"], "fractions"),
    ("ratio-fractions-text", ["frequency-ratio", "--fractions", "a,b"], "fractions"),
    ("ratio-side-spans", ["frequency-ratio", "--side-spans", "floating"], "arguments"),
    ("ratio-plot-dir", ["frequency-ratio", "--plot", "{d}/prev_out"], "plot"),
    # ---- flutter
    ("flutter-speeds-inf", ["flutter", "--speeds", "0:inf:1"], "speeds"),
    ("flutter-speeds-nan", ["flutter", "--speeds", "0:nan:1"], "speeds"),
    ("flutter-speeds-million", ["flutter", "--speeds", "0:100:0.00001"], "speeds"),
    ("flutter-speeds-huge-value", ["flutter", "--speeds", "0,1e300"], "speeds"),
    ("flutter-speeds-zero-step", ["flutter", "--speeds", "0:10:0"], "speeds"),
    ("flutter-speeds-two-colons", ["flutter", "--speeds", "0:10"], "speeds"),
    ("flutter-modes-huge", ["flutter", "--modes", "100000"], "modes"),
    ("flutter-modes-neg", ["flutter", "--modes=-3"], "modes"),
    ("flutter-modes-float", ["flutter", "--modes", "2.5"], "modes"),
    ("flutter-modes-beyond-model", ["flutter", B, "{d}/bad_coarse.toml", "--modes", "90"],
     "modes"),
    ("flutter-rfa-bogus", ["flutter", "--rfa", "bogus"], "rfa"),
    ("flutter-order-bogus", ["flutter", "--order", "bogus"], "order"),
    ("flutter-controller-missing", ["flutter", "--controller", "{d}/nosuch.toml"], "controller"),
    ("flutter-controller-dir", ["flutter", "--controller", "{d}/prev_out"], "controller"),
    ("flutter-controller-unstable", ["flutter", "--controller", "{d}/ctrl_unstable.toml"],
     "controller.a2"),
    ("flutter-controller-typo", ["flutter", "--controller", "{d}/ctrl_typo.toml"],
     "controller.gain_limt"),
    ("flutter-controller-rfa", ["flutter", "--controller", "{d}/ctrl_high_gain.toml", "--rfa",
                                "jones"], "controller"),
    ("flutter-plot-no-folder", ["flutter", "--plot", "{d}/nodir/f.png"], "plot"),
    # ---- erection
    ("erection-fractions-zero", ["erection", "--fractions", "0,0.5"], "erected_fraction"),
    ("erection-fractions-huge", ["erection", "--fractions", "0.1:1:0.0000001"], "fractions"),
    ("erection-speeds-neg", ["erection", "--speeds=-10:10:1"], "speeds"),
    ("erection-modes-0", ["erection", "--modes", "0"], "modes"),
    # ---- section
    ("section-f-torsion-1e300", ["section", *SECTION[:-3], "1e300", *SECTION[-2:]], "f-torsion"),
    ("section-mass-nan", ["section", "--mass", "nan", *SECTION[2:]], "mass"),
    ("section-mass-inf", ["section", "--mass", "inf", *SECTION[2:]], "mass"),
    ("section-half-chord-0", ["section", *SECTION[:-1], "0"], "half-chord"),
    ("section-damping-1", ["section", *SECTION, "--damping-ratio", "1"], "damping-ratio"),
    ("section-air-neg", ["section", *SECTION, "--air-density=-1"], "air-density"),
    ("section-speeds-inf", ["section", *SECTION, "--speeds", "0:inf:1"], "speeds"),
    ("section-missing-mass", ["section", *SECTION[2:]], "arguments"),
    ("section-aero-bogus", ["section", *SECTION, "--aero", "bogus"], "arguments"),
    # ---- state-space
    ("ss-speed-inf", ["state-space", "--speed", "inf", "--out", "{d}/prev.npz"], "speed"),
    ("ss-speed-1e300", ["state-space", "--speed", "1e300", "--out", "{d}/prev.npz"], "speed"),
    ("ss-modes-huge", ["state-space", "--speed", "10", "--modes", "100000", "--out",
                       "{d}/prev.npz"], "modes"),
    ("ss-out-dir", ["state-space", "--speed", "10", "--out", "{d}/prev_out"], "out"),
    ("ss-controller-missing", ["state-space", "--speed", "10", "--controller", "{d}/no.toml",
                               "--out", "{d}/prev.npz"], "controller"),
    ("ss-bad-bridge", ["state-space", "--speed", "10", B, "{d}/bad_gj_1e300.toml", "--out",
                       "{d}/prev.npz"], "deck.gj_nm2"),
    # ---- derivatives
    ("derivatives-bridge-unknown", ["derivatives", "--bridge", "nosuch"], "bridge"),
    ("derivatives-lags-neg", ["derivatives", "--lags", "-3"], "lags"),
    ("derivatives-points-0", ["derivatives", "--points", "0"], "points"),
    ("derivatives-extra-positional", ["derivatives", "extra"], "arguments"),
    ("flutter-section-case-controller", ["flutter", B, "iabse-1.1a", "--controller",
                                         "{d}/no.toml"], "controller"),
    # a flutter-derivative bridge's buffeting is quasi-steady: thin-aerofoil refused
    ("buffeting-derivative-loads", ["buffeting", B, "iabse-2a:bb3", "--loads", "thin-aerofoil"],
     "loads"),
    # ---- rfa
    ("rfa-name-bogus", ["rfa", "--name", "bogus"], "arguments"),
    ("rfa-extra-positional", ["rfa", "extra"], "arguments"),
    # ---- buffeting
    ("buffeting-seed-neg", ["buffeting", "--method", "monte-carlo", "--seed", "-1"], "seed"),
    ("buffeting-records-0", ["buffeting", "--method", "monte-carlo", "--records", "0"],
     "records"),
    ("buffeting-speeds-zero", ["buffeting", "--speeds", "0:10:1"], "speeds"),
    ("buffeting-speeds-inf", ["buffeting", "--speeds", "1:inf:1"], "speeds"),
    ("buffeting-ti-nan", ["buffeting", "--turbulence-intensity", "nan"], "turbulence-intensity"),
    ("buffeting-ti-zero", ["buffeting", "--turbulence-intensity", "0"], "turbulence-intensity"),
    ("buffeting-coherence-inf", ["buffeting", "--coherence-decay", "inf"], "coherence-decay"),
    ("buffeting-spectrum", ["buffeting", "--spectrum", "bogus"], "arguments"),
    ("buffeting-modes-huge", ["buffeting", "--modes", "100000"], "modes"),
    ("buffeting-plot-suffix", ["buffeting", "--plot", "{d}/prev.npz"], "plot"),
    # ---- optimise
    ("robustness-no-controller", ["robustness"], "controller"),
    ("robustness-missing-controller", ["robustness", "--controller", "{d}/nosuch.toml"],
     "controller"),
    ("robustness-samples-0", ["robustness", "--controller", "{d}/nosuch.toml", "--samples", "0"],
     "samples"),
    # ---- actuators (a valid controller file: the limits and options fail before it loads)
    ("actuators-no-controller", ["actuators"], "controller"),
    ("actuators-missing-controller", ["actuators", "--controller", "{d}/nosuch.toml"],
     "controller"),
    *[(f"actuators-{name}", ["actuators", "--controller", "{d}/ctrl_high_gain.toml", *extra],
       field) for name, extra, field in (
        ("angle-limit-0", ["--flap-angle-limit-deg", "0"], "flap_angle_limit_deg"),
        ("angle-limit-nan", ["--flap-angle-limit-deg", "nan"], "flap_angle_limit_deg"),
        ("angle-limit-180", ["--flap-angle-limit-deg", "180"], "flap_angle_limit_deg"),
        ("rate-limit-neg", ["--flap-rate-limit-deg-s", "-40"], "flap_rate_limit_deg_s"),
        ("rate-limit-inf", ["--flap-rate-limit-deg-s", "inf"], "flap_rate_limit_deg_s"),
        ("bandwidth-0", ["--actuator-bandwidth-rad-s", "0"], "actuator_bandwidth_rad_s"),
        ("card-angle-neg", ["--card", "{d}/design_angle.toml"], "flap_angle_limit_deg"),
        ("card-missing", ["--card", "{d}/nosuch.toml"], "design"),
        ("duration-1", ["--duration-s", "1"], "duration-s"),
        ("duration-nan", ["--duration-s", "nan"], "duration-s"),
        ("near-critical-1", ["--near-critical", "1"], "near-critical"),
        ("records-1", ["--records", "1"], "records"),
        ("seed-neg", ["--seed", "-1"], "seed"),
        ("speeds-zero", ["--speeds", "0,10"], "speeds"),
        ("modes-0", ["--modes", "0"], "modes"),
        ("out-npz", ["--out", "{d}/prev.npz"], "out"))],
    ("robustness-stuck-angle-alone", ["robustness", "--controller", "{d}/ctrl_high_gain.toml",
                                      "--stuck-angle-deg", "5"], "stuck-angle-deg"),
    ("robustness-stuck-angle-nan", ["robustness", "--controller", "{d}/ctrl_high_gain.toml",
                                    "--failures", "--stuck-angle-deg", "nan"], "stuck-angle-deg"),
    ("robustness-failures-out", ["robustness", "--controller", "{d}/ctrl_high_gain.toml",
                                 "--failures", "--out", "{d}/prev.npz"], "out"),
    ("optimise-dir", ["optimise", "{d}/prev_out", "--out", "{d}/prev_out"], "definition"),
    ("optimise-missing", ["optimise", "{d}/nosuch.toml", "--out", "{d}/prev_out"],
     "definition"),
    ("optimise-binary", ["optimise", "{d}/binary.toml", "--out", "{d}/prev_out"], "design"),
    ("optimise-a2-bounds", ["optimise", "{d}/design_a2.toml", "--out", "{d}/prev_out"],
     "a2_bounds"),
    ("optimise-options", ["optimise", "{d}/design_options.toml", "--out", "{d}/prev_out"],
     "options"),
    ("optimise-design", ["optimise", "{d}/design_design.toml", "--out", "{d}/prev_out"],
     "design"),
    ("optimise-n-modes", ["optimise", "{d}/design_nmodes.toml", "--out", "{d}/prev_out"],
     "n_modes"),
    ("optimise-bool", ["optimise", "{d}/design_bool.toml", "--out", "{d}/prev_out"],
     "optimise_placement"),
    ("optimise-bridge", ["optimise", "{d}/design_bridge.toml", "--out", "{d}/prev_out"],
     "bridge"),
    ("optimise-out-file", ["optimise", "--out", "{d}/prev.npz"], "out"),
    # the folder's parent is a file: found only after a 3-minute design before the fix
    ("optimise-out-under-file", ["optimise", "--out", "{d}/prev.npz/sub"], "out"),
    # the folder's parent does not exist (was reported as "not writable")
    ("optimise-out-no-parent", ["optimise", "--out", "{d}/no_such_parent/opt"], "out"),
    # ---- placement
    ("placement-missing", ["placement", "{d}/nosuch.toml"], "definition"),
    ("placement-bool", ["placement", "{d}/design_bool.toml"], "optimise_placement"),
    ("placement-target-0", ["placement", "--target-m-s", "0"], "target-m-s"),
    ("placement-target-nan", ["placement", "--target-m-s", "nan"], "target-m-s"),
    ("placement-target-huge", ["placement", "--target-m-s", "1e6"], "target-m-s"),
    ("placement-workers-0", ["placement", "--workers", "0"], "workers"),
    ("placement-steps-neg", ["placement", "--max-steps", "-1"], "max-steps"),
    ("placement-out-file", ["placement", "--out", "{d}/prev.npz"], "out"),
    ("placement-out-no-parent", ["placement", "--out", "{d}/no_such_parent/p"], "out"),
    # ---- study
    ("study-missing", ["study", "{d}/nosuch.toml", "--out", "{d}/prev_study"], "study"),
    ("study-dir", ["study", "{d}/adir.toml", "--out", "{d}/prev_study"], "study"),
    ("study-malformed", ["study", "{d}/bad_malformed.toml", "--out", "{d}/prev_study"],
     "study"),
    ("study-rfa", ["study", "{d}/study_rfa.toml", "--out", "{d}/prev_study"], "flutter.rfa"),
    ("study-unknown-option", ["study", "{d}/study_unknown_opt.toml", "--out", "{d}/prev_study"],
     "flutter.modez"),
    ("study-modes", ["study", "{d}/study_modes.toml", "--out", "{d}/prev_study"],
     "flutter.modes"),
    ("study-speeds", ["study", "{d}/study_speeds.toml", "--out", "{d}/prev_study"],
     "flutter.speeds"),
    ("study-speeds-type", ["study", "{d}/study_speeds_type.toml", "--out", "{d}/prev_study"],
     "flutter.speeds"),
    ("study-design-a2", ["study", "{d}/study_design.toml", "--out", "{d}/prev_study"],
     "design.a2_bounds"),
    ("study-design-7", ["study", "{d}/study_design7.toml", "--out", "{d}/prev_study"], "design"),
    ("study-design-key", ["study", "{d}/study_design_key.toml", "--out", "{d}/prev_study"],
     "design.frobnicate"),
    ("study-mc-seed", ["study", "{d}/study_buffeting.toml", "--out", "{d}/prev_study"],
     "buffeting.mc_seed"),
    ("study-spectrum", ["study", "{d}/study_spectrum.toml", "--out", "{d}/prev_study"],
     "buffeting.spectrum"),
    ("study-check-str", ["study", "{d}/study_bool.toml", "--out", "{d}/prev_study"],
     "sensitivity.check"),
    ("study-fractions", ["study", "{d}/study_fractions.toml", "--out", "{d}/prev_study"],
     "erection.fractions"),
    ("study-side-spans", ["study", "{d}/study_side.toml", "--out", "{d}/prev_study"],
     "erection.side_spans"),
    ("study-bad-bridge", ["study", "{d}/study_bridge.toml", "--out", "{d}/prev_study"],
     "deck.gj_nm2"),
    ("study-out-file", ["study", "{d}/study_ok.toml", "--out", "{d}/prev.npz"], "out"),
    # ---- doe
    ("doe-rfa", ["doe", "{d}/doe_rfa.toml", "--out", "{d}/prev_doe"], "options.rfa"),
    ("doe-options-str", ["doe", "{d}/doe_options.toml", "--out", "{d}/prev_doe"], "options"),
    ("doe-design-int", ["doe", "{d}/doe_design.toml", "--out", "{d}/prev_doe"], "design"),
    ("doe-quick-options", ["doe", "{d}/doe_quick.toml", "--quick", "--out", "{d}/prev_doe"],
     "options"),
    ("doe-levels-huge", ["doe", "{d}/doe_levels.toml", "--out", "{d}/prev_doe"],
     "design.levels"),
    ("doe-unknown-parameter", ["doe", "{d}/doe_param.toml", "--out", "{d}/prev_doe"],
     "parameters.deck.colour"),
    ("doe-empty-range", ["doe", "{d}/doe_range.toml", "--out", "{d}/prev_doe"],
     "parameters.deck.gj_nm2"),
    ("doe-modes-0", ["doe", "{d}/doe_modes.toml", "--out", "{d}/prev_doe"], "options.modes"),
    ("doe-workers-0", ["doe", "{d}/doe_rfa.toml", "--workers", "0"], "workers"),
    ("doe-no-file", ["doe"], "arguments"),
    ("doe-out-under-file", ["doe", "{d}/doe_ok.toml", "--out", "{d}/prev.npz/sub"], "out"),
    # ---- sensitivity
    ("sens-parameter", ["sensitivity", "--parameters", "deck.colour"], "parameters"),
    ("sens-speeds-inf", ["sensitivity", "--speeds", "0:inf:1"], "speeds"),
    ("sens-modes-huge", ["sensitivity", "--modes", "100000"], "modes"),
    ("sens-global-method", ["sensitivity", "--global", "bogus"], "arguments"),
    ("sens-global-speeds", ["sensitivity", "--global", "morris", "--speeds", "0:inf:1",
                            "--out", "{d}/prev_doe"], "speeds"),
    ("sens-global-modes", ["sensitivity", "--global", "morris", "--modes", "0",
                           "--out", "{d}/prev_doe"], "modes"),
    ("sens-global-samples", ["sensitivity", "--global", "morris", "--samples", "0", "--out",
                             "{d}/prev_doe"], "samples"),
    ("sens-global-sobol-samples", ["sensitivity", "--global", "sobol", "--samples", "3",
                                   "--out", "{d}/prev_doe"], "samples"),
    ("sens-global-parameter", ["sensitivity", "--global", "morris", "--parameters",
                               "deck.colour", "--out", "{d}/prev_doe"], "parameters"),
    # ---- no command
    ("unknown-command", ["frobnicate"], "arguments"),
]


def _argv(argv, folder) -> list[str]:
    return [a.format(d=folder) for a in argv]


def test_matrix_covers_every_command():
    """At least 60 cases, and every command of bridgeflap.design.cli.main.COMMANDS has some."""
    assert len(CASES) >= 60
    used = {argv[0] for _, argv, _ in CASES}
    assert {c.name for c in COMMANDS} <= used


@pytest.mark.parametrize("argv,field", [c[1:] for c in CASES], ids=[c[0] for c in CASES])
def test_bad_input(capsys, monkeypatch, folder, argv, field):
    monkeypatch.chdir(folder)
    before = _snapshot(folder)
    rc = main([*_argv(argv, folder), "--json"])
    cap = capsys.readouterr()
    assert rc == 2, cap.err
    assert cap.out == ""
    assert cap.err.count("\n") == 1 and cap.err.endswith("\n"), cap.err
    assert cap.err.startswith("bridgeflap: error: "), cap.err
    assert "Traceback" not in cap.err
    assert field in cap.err, cap.err
    assert _snapshot(folder) == before  # nothing written, earlier outputs byte-identical


@pytest.mark.parametrize("argv", [["flutter", "--speeds", "0:inf:1"],
                                  ["state-space", "--speed", "nan", "--out", "{d}/prev.npz"]],
                         ids=["flutter", "state-space"])
def test_bad_input_without_json(capsys, monkeypatch, folder, argv):
    """Without --json the contract is the same (nothing on stdout)."""
    monkeypatch.chdir(folder)
    before = _snapshot(folder)
    rc = main(_argv(argv, folder))
    cap = capsys.readouterr()
    assert rc == 2 and cap.out == "" and cap.err.count("\n") == 1
    assert _snapshot(folder) == before


SUBPROCESS_CASES = [
    (["section", *SECTION[:-3], "1e300", *SECTION[-2:], "--json"], "f-torsion"),
    (["buffeting", "--method", "monte-carlo", "--seed", "-1", "--json"], "seed"),
    (["optimise", "{d}/prev_out", "--json"], "definition"),
]


@pytest.mark.parametrize("argv,field", SUBPROCESS_CASES, ids=["section", "buffeting",
                                                              "optimise"])
def test_bad_input_subprocess(folder, argv, field):
    """The real process: exit 2, one line, no traceback (python -m bridgeflap.design.cli.main of
    this tree)."""
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1", PYTHONPATH=str(ROOT))
    before = _snapshot(folder)
    p = subprocess.run([sys.executable, "-m", "bridgeflap.design.cli.main", *_argv(argv, folder)],
                       capture_output=True, text=True, env=env, cwd=folder, timeout=300)
    assert p.returncode == 2, p.stderr
    assert p.stdout == ""
    assert p.stderr.count("\n") == 1 and field in p.stderr and "Traceback" not in p.stderr
    assert _snapshot(folder) == before


# ------------------------------------------------------------------------- internal faults


def _broken(args):
    raise ZeroDivisionError("simulated internal fault")


@pytest.fixture
def broken_rfa(monkeypatch):
    """The ``rfa`` command replaced by one with a bug."""
    monkeypatch.setattr(cli, "COMMANDS", tuple(
        cli.Command(c.name, c.help, c.arguments, _broken) if c.name == "rfa" else c
        for c in cli.COMMANDS))


def test_internal_fault_is_one_line(capsys, broken_rfa):
    rc = main(["rfa", "--json"])
    cap = capsys.readouterr()
    assert rc == 1
    assert cap.out == ""
    assert cap.err.count("\n") == 1, cap.err
    assert "Traceback" not in cap.err
    assert "bug" in cap.err and "ZeroDivisionError" in cap.err and "--debug" in cap.err


@pytest.mark.parametrize("argv", [["--debug", "rfa"], ["rfa", "--debug"]],
                         ids=["before", "after"])
def test_internal_fault_debug_traceback(capsys, broken_rfa, argv):
    rc = main(argv)
    cap = capsys.readouterr()
    assert rc == 1
    assert "Traceback" in cap.err and "simulated internal fault" in cap.err


def test_debug_flag_is_harmless(capsys):
    """``--debug`` on a good command changes nothing."""
    rc = main(["rfa", "--json", "--debug"])
    cap = capsys.readouterr()
    assert rc == 0 and json.loads(cap.out)["name"] == "rfa4"


# ------------------------------------------------------------------------- A9: gain limit


def test_controller_over_its_gain_limit_is_flagged(capsys, folder):
    """K = 20/(0.1 s^2 + s + 1) peaks at |K(0)| = 20 > its limit 15: flagged, warned once."""
    rc = main(["flutter", "--controller", str(folder / "ctrl_high_gain.toml"), "--speeds",
               "0:20:10", "--modes", "4", "--json"])
    cap = capsys.readouterr()
    assert rc == 0, cap.err
    r = json.loads(cap.out)
    # the peak of a low-pass K with a1^2 >= 2 a2 is its static gain b0 = 20 (no resonance)
    assert r["controller_max_gain"] == pytest.approx(20.0, rel=1e-9)
    assert r["controller_gain_limit"] == 15.0
    assert r["controller_within_gain_limit"] is False
    warnings = [ln for ln in cap.err.splitlines() if "warning" in ln]
    assert len(warnings) == 1 and "gain limit" in warnings[0]


def test_modes_retained_is_what_was_asked(capsys):
    """``modes_retained`` equals the request, and a request beyond the model is refused
    (the bad-input matrix has that case); here the largest allowed request on Humber."""
    from bridgeflap.design.io.options import MAX_MODES

    rc = main(["flutter", "--modes", str(MAX_MODES), "--speeds", "0:10:10", "--json"])
    cap = capsys.readouterr()
    assert rc == 0, cap.err
    assert json.loads(cap.out)["modes_retained"] == MAX_MODES


def test_state_space_controller_flag(capsys, tmp_path, folder):
    """state-space with the same over-limit controller: written, flagged, warned."""
    out = tmp_path / "cl.npz"
    rc = main(["state-space", "--speed", "10", "--modes", "4", "--controller",
               str(folder / "ctrl_high_gain.toml"), "--out", str(out), "--json"])
    cap = capsys.readouterr()
    assert rc == 0, cap.err
    r = json.loads(cap.out)
    assert r["controller_within_gain_limit"] is False and out.is_file()
    assert sum("warning" in ln for ln in cap.err.splitlines()) == 1


# ------------------------------------------------------------------------- plausible ranges


@pytest.mark.parametrize("path", ["deck.mass_kg_per_m", "deck.gj_nm2", "cable.area_m2",
                                  "cable.modulus_pa", "aero.air_density_kg_m3"])
def test_spec_ranges_hold_through_replace(humber, path):
    """The ranges apply to every way a value enters (here ``spec.replace``, which DOE and
    sensitivity cases use), naming the field; the built-in bridge and its variants are inside
    them (the fixture loads it)."""
    from bridgeflap.model.errors import BridgeflapInputError
    from bridgeflap.model.structure.spec import PLAUSIBLE_RANGES

    lo, hi = PLAUSIBLE_RANGES[path]
    for bad in (hi * 10, float("nan"), -1.0):
        with pytest.raises(BridgeflapInputError, match=re.escape(path)):
            humber.replace(**{path: bad})
    humber.replace(**{path: hi})  # the bounds themselves are accepted
