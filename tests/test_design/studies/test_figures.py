"""Figures (model/axes.py, model/{structure,stability,response}/plots.py,
design/control/results/figures.py, design/sensitivity/figures.py,
design/studies/figures.py): what an engineer reads off them is there.

Every test draws on the Agg backend and checks the drawn data, not the pixels: axis limits
enclose all the data (nothing clipped), each family/loop/output has its own artist, units are in
the labels, the marked speeds are the result's own.
"""

from types import SimpleNamespace

import matplotlib
import numpy as np
import pytest

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from bridgeflap.design.cli.common import save_figure  # noqa: E402
from bridgeflap.design.control.results.figures import (  # noqa: E402
    bode,
    compensator_response,
    flap_layout,
    margins,
)
from bridgeflap.design.sensitivity.figures import morris_mu_sigma  # noqa: E402
from bridgeflap.design.studies.document import Document  # noqa: E402
from bridgeflap.design.studies.figures import fig5  # noqa: E402
from bridgeflap.model.aeroelastic.control import Compensator, Controller  # noqa: E402
from bridgeflap.model.analysis import flutter, modal_model  # noqa: E402
from bridgeflap.model.axes import data_limits  # noqa: E402

SPEEDS = np.arange(0.0, 100.0 + 1e-9, 2.0)


@pytest.fixture(scope="module")
def sweep(coarse_humber):
    return flutter(coarse_humber, SPEEDS, 6).sweep


@pytest.fixture(autouse=True)
def _close():
    yield
    plt.close("all")


def _inside(ax, x=None, y=None):
    xlo, xhi = ax.get_xlim()
    ylo, yhi = ax.get_ylim()
    if x is not None:
        x = np.asarray(x, float)[np.isfinite(x)]
        assert xlo <= x.min() and x.max() <= xhi
    if y is not None:
        y = np.asarray(y, float)[np.isfinite(y)]
        assert ylo <= y.min() and y.max() <= yhi


def test_vg_vf_axes_hold_every_branch_and_name_it(sweep):
    assert sweep.flutter.status == "converged"  # so that TS1 runs negative past flutter
    ax0, ax1, ax2 = sweep.plot().axes[:3]  # the colour bar of the root locus is the 4th
    z = 100 * sweep.damping_ratios()
    assert np.nanmin(z) < -1.0  # the branch that used to run off the old -5 % axis
    _inside(ax1, y=z)  # unclipped: the old axis was fixed at -5 .. 15 %
    _inside(ax2, y=sweep.frequencies_hz())
    labels = [t.get_text() for t in ax2.get_legend().get_texts()]
    assert set(sweep.branch_labels) <= set(labels)
    assert f"flutter {sweep.flutter.speed:.2f} m/s" in labels
    assert "[%]" in ax1.get_ylabel() and "[Hz]" in ax2.get_ylabel()
    assert "[m/s]" in ax1.get_xlabel()


def test_root_locus_one_unit_system_and_open_loop_overlay(sweep):
    ax = sweep.plot_root_locus(reference=sweep)
    assert ax.get_xlabel().endswith("[1/s]") and ax.get_ylabel().endswith("[rad/s]")
    _inside(ax, x=sweep.branches.real, y=sweep.branches.imag)
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert "open loop" in labels and "closed loop" in labels


def test_every_v_g_branch_has_its_own_colour_style_and_marker():
    from bridgeflap.model.stability.plots import branch_styles

    # Humber's 30-mode labels: 17+ vertical branches used to repeat colour and style (VS1/VS5)
    labels = ([f"VS{i}" for i in range(1, 10)] + [f"VA{i}" for i in range(1, 7)]
              + [f"V-barton{i}" for i in range(1, 5)] + [f"TS{i}" for i in range(1, 5)]
              + ["TA1", "TA2", "T-barton1", "T-hessle1"] + [f"X{i}" for i in range(25)])
    styles = branch_styles(labels)
    keys = [(s["color"], s["ls"], s["marker"]) for s in styles]
    assert len(set(keys)) == len(labels)
    # the family stays in the line style
    assert all((s["ls"] == "-") == lab.startswith("T") for s, lab in zip(styles, labels,
                                                                         strict=True))


def test_v_g_lines_are_unique_on_a_real_sweep(coarse_humber):
    res = flutter(coarse_humber, SPEEDS, 30).sweep
    assert len(res.branch_labels) > 20
    ax1 = res.plot().axes[1]  # root locus, V-g, V-f
    lines = [ln for ln in ax1.get_lines() if ln.get_label() in res.branch_labels]
    keys = {(ln.get_color(), ln.get_linestyle(), ln.get_marker()) for ln in lines}
    assert len(lines) == len(res.branch_labels) == len(keys)


@pytest.mark.parametrize("layout", [None, "tight", "constrained"])
def test_root_locus_colour_bar_clears_the_frequency_axis(sweep, layout):
    fig, ax = plt.subplots(figsize=(6, 4.5), layout=layout)
    sweep.plot_root_locus(ax=ax)
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    cbar = fig.axes[-1]
    sec = [c for c in ax.child_axes if "Hz" in c.get_ylabel()][0]
    # the frequency axis' ticks and label end left of the colour bar's box
    assert sec.get_tightbbox(renderer).x1 < cbar.get_window_extent(renderer).x0


def test_mode_shapes_one_panel_per_family_with_towers(coarse_humber):
    modal = modal_model(coarse_humber)
    axes = modal.plot().axes
    assert len(axes) == 3
    for ax, fam in zip(axes, ("vertical", "torsional", "lateral"), strict=True):
        assert ax.get_ylabel().startswith(fam)
        labels = [t.get_text() for t in ax.get_legend().get_texts()]
        assert "tower" in labels and len(labels) == 4  # three modes and the towers
        assert all(lab[0] == fam[0].upper() for lab in labels if lab != "tower")
        towers = [ln for ln in ax.get_lines() if ln.get_linestyle() == ":"]
        assert len(towers) == len(coarse_humber.spans) - 1
    # VA1 and TA1 are in different panels now (VA1 was hidden under TA1 on one axis)
    assert any(t.get_text().startswith("VA1") for t in axes[0].get_legend().get_texts())


def test_erection_completed_bridge_is_its_own_marker():
    from bridgeflap.model.analysis import ErectionResult

    st = [{"erected_fraction": f, "flutter_speed_m_s": 40.0 + 10 * f,
           "divergence_speed_m_s": 50.0} for f in (0.4, 0.7, 1.0)]
    res = ErectionResult("b", tuple(st), {"flutter_speed_m_s": 70.0,
                                          "divergence_speed_m_s": 75.0}, "bare")
    ax = res.plot().axes[0]
    done = [ln for ln in ax.get_lines() if "completed" in ln.get_label()]
    assert len(done) == 2 and all(len(ln.get_xdata()) == 1 for ln in done)
    erecting = [ln for ln in ax.get_lines() if "erecting" in ln.get_label()]
    assert all(70.0 not in ln.get_ydata() for ln in erecting)  # not joined to the curve


def test_erection_and_frequency_ratio_ring_the_hybrid_stages():
    from bridgeflap.model.analysis import ErectionResult, FrequencyRatioResult

    st = [{"erected_fraction": f, "flutter_speed_m_s": 40.0 + 10 * f,
           "divergence_speed_m_s": 50.0, "critical_mechanism": "flutter",
           "critical_branch_label": lab}
          for f, lab in ((0.2, "T-barton1"), (0.5, "TS1"), (0.95, "V-hessle2"))]
    ax = ErectionResult("b", tuple(st), {}, "bare").plot().axes[0]
    ring = [ln for ln in ax.get_lines() if ln.get_label().startswith("hybrid stage")]
    assert len(ring) == 1 and list(ring[0].get_xdata()) == [20.0, 95.0]
    assert list(ring[0].get_ydata()) == [42.0, 49.5]  # on the flutter curve: it governs
    assert sorted(t.get_text() for t in ax.texts) == ["T-barton1", "V-hessle2"]
    rows = [{"erected_fraction": f, "ratio_full_gj": 1.2, "ratio_half_gj": 1.1 + f,
             "torsional_mode": tm, "vertical_mode": "VS1", "torsional_hybrid": h,
             "vertical_hybrid": False}
            for f, tm, h in ((0.3, "T-barton1", True), (0.6, "TS1", False))]
    ax = FrequencyRatioResult("b", tuple(rows), {"ratio": 2.0}, "bare").plot().axes[0]
    ring = [ln for ln in ax.get_lines() if ln.get_label().startswith("hybrid stage")]
    assert len(ring) == 1 and list(ring[0].get_xdata()) == [30.0]
    assert [t.get_text() for t in ax.texts] == ["T-barton1"]


K = Compensator(b2=0.5, b1=-1.2, b0=-2.4, a2=0.08, a1=0.4)


def test_bode_in_hz_with_the_gain_limit():
    f = np.array([1e-3, 0.05, 0.3, 2.0])
    # scipy.signal.freqs against the compensator's own evaluation: same rational function,
    # round-off only (1e-12 relative)
    np.testing.assert_allclose(compensator_response(K, f),
                               K.frequency_response(2 * np.pi * f), rtol=1e-12)
    ax0, ax1 = bode(K, 15.0)
    assert ax1.get_xlabel() == "frequency [Hz]"
    limit = [ln for ln in ax0.get_lines() if ln.get_label().startswith("gain limit")]
    assert limit and np.allclose(limit[0].get_ydata(), 15.0)
    _inside(ax0, y=[15.0])


def _controller(n=5):
    return Controller(K, tuple(np.linspace(-400, 400, n)), 50.0)


def test_flap_layout_draws_every_flap_on_the_deck(coarse_humber):
    _, ax = plt.subplots()
    flap_layout(ax, _controller(), coarse_humber, 3.0)
    flaps = [p for p in ax.patches if p.get_width() == 50.0]
    assert len(flaps) == 2 * 5  # leading and trailing edge
    towers = [ln for ln in ax.get_lines() if ln.get_label() == "towers"][0]
    L = coarse_humber.main_span.length_m
    assert np.allclose(sorted(towers.get_xdata()), [-L / 2, L / 2])


def test_margins_plot_the_robust_margin_per_speed():
    t = {"10": 1.5, "40": 2.0, "85": 4.0}
    res = SimpleNamespace(
        settings=SimpleNamespace(zeta_min=0.005, flap_chord_m=3.0),
        abscissa_speeds_m_s=np.array([0.0, 40.0, 85.0]), abscissa_1_s=np.array([-.01, -.02, -.01]),
        extras={"open_loop_abscissa": np.array([-.01, 0.0, .03]),
                "damping_ratio": np.array([0.01, 0.008, 0.006])},
        best=SimpleNamespace(t_inf_by_speed=lambda: t), candidate=_controller())
    a0, a1, a2, a3 = margins(res)
    line = [ln for ln in a2.get_lines() if ln.get_marker() == "o"][0]
    np.testing.assert_allclose(line.get_ydata(), [1 / 1.5, 1 / 2.0, 1 / 4.0])
    np.testing.assert_allclose(line.get_xdata(), [10, 40, 85])
    assert len([p for p in a3.patches if p.get_width() == 50.0]) == 10


def test_fig5_marks_the_given_open_loop_flutter_and_both_buffeting_panels(sweep):
    def buf(scale):
        return SimpleNamespace(speeds=np.array([10.0, 20.0, 30.0]),
                               rms_vertical=scale * np.array([3e-3, 3e-2, 9e-2]),
                               rms_torsion=scale * np.array([1e-5, 1e-4, 3e-4]))

    fig = fig5(sweep, sweep, buf(1.0), buf(0.5), _controller(), open_loop_flutter_m_s=65.45)
    ax0, ax1, ax2 = fig.axes[:3]
    for ax in (ax1, ax2):
        labels = [t.get_text() for t in ax.get_legend().get_texts()]
        assert {"open loop", "closed loop", "open-loop flutter 65.45 m/s"} <= set(labels)
    assert "[deg]" in ax2.get_ylabel() and "[mm]" in ax1.get_ylabel()
    _inside(ax2, y=np.degrees([1e-5, 3e-4]))
    _inside(ax1, y=[3.0, 90.0])  # [mm]


def test_buffeting_panels_in_mm_and_deg_with_the_seed_ordinate_on_the_right():
    from bridgeflap.model.response.plots import buffeting_panels

    res = SimpleNamespace(speeds=np.array([10.0, 20.0, 30.0]),
                          rms_vertical=np.array([2e-3, 1e-2, 4e-2]),
                          rms_torsion=np.array([1e-5, 1e-4, 3e-4]), deck_width_m=28.5,
                          status=("ok", "ok", "ok"), inputs={})
    ax0, ax1 = buffeting_panels({"a": res})
    assert ax0.get_ylabel().endswith("[mm]") and ax1.get_ylabel().endswith("[deg]")
    np.testing.assert_allclose(ax0.get_lines()[0].get_ydata(), [2.0, 10.0, 40.0])
    np.testing.assert_allclose(ax1.get_lines()[0].get_ydata(), np.degrees([1e-5, 1e-4, 3e-4]))
    sec = [c for c in ax0.child_axes if "2b" in c.get_ylabel()]
    assert len(sec) == 1  # sigma_z / 2b, the seed's Fig. 4 ordinate, for comparison


def test_morris_plane_holds_every_input():
    idx = {"flutter_speed_m_s": {"a": {"mu_star": 1.0, "sigma": 3.0},
                                 "b": {"mu_star": 4.0, "sigma": 0.5}},
           "divergence_speed_m_s": {"a": {"mu_star": 2.0, "sigma": 2.5}}}
    _, ax = plt.subplots()
    morris_mu_sigma(ax, idx)
    _inside(ax, x=[1.0, 4.0, 2.0], y=[3.0, 0.5, 2.5])
    assert "μ*" in ax.get_xlabel() and "[m/s]" in ax.get_ylabel()


def test_data_limits_pad_and_ignore_nan():
    lo, hi = data_limits([np.nan, -3.0, 7.0, np.inf])
    assert lo < -3.0 and hi > 7.0


@pytest.mark.parametrize(("suffix", "magic"), [(".svg", b"<?xml"), (".pdf", b"%PDF")])
def test_figure_type_follows_the_extension(tmp_path, suffix, magic):
    fig, ax = plt.subplots()
    ax.plot([0, 1])
    p = save_figure(fig, tmp_path / f"f{suffix}")
    assert p.read_bytes().startswith(magic)


def test_document_renders_the_same_cells_twice(tmp_path):
    fig, ax = plt.subplots()
    ax.plot([0, 1])
    save_figure(fig, tmp_path / "a.png")
    doc = Document()
    doc.heading(1, "T")
    doc.table([("x <1>", "1.25")], ["name", "value [m]"])
    doc.figure("a.png", "caption")
    md, html = doc.markdown(), doc.html(tmp_path)
    row = [c.strip() for c in md.splitlines()[4].strip("|").split("|")]
    assert row == ["x <1>", "1.25"] and "![a](a.png)" in md
    assert "<td>x &lt;1&gt;</td>" in html and "<td>1.25</td>" in html
    assert "data:image/png;base64," in html and "a.png\"" not in html


def test_imported_mode_shapes_by_family_with_the_main_span_ends():
    from bridgeflap.model.structure.loader import load_bridge

    axes = modal_model(load_bridge("iabse-2a")).plot().axes
    assert [ax.get_ylabel().split("\n")[0] for ax in axes] == ["vertical", "torsional",
                                                                 "lateral"]
    for ax in axes:
        assert len([ln for ln in ax.get_lines() if ln.get_linestyle() == ":"]) == 2


def test_bode_marks_the_true_peak_of_a_lightly_damped_compensator():
    # the default design's K (damping ratio of its poles ~3 %): its resonance is narrower than
    # the 800-point plotting grid, which read 9.70 where sup |K| = 9.90; the analytic
    # stationary frequencies join the grid, so the marker equals max_gain (round-off: 1e-9)
    k = Compensator(b2=-0.8478, b1=0.2983, b0=-2.7450, a2=0.2828, a1=0.0333)
    ax0, _ = bode(k, 15.0)
    peak = [ln for ln in ax0.get_lines() if ln.get_label().startswith("peak")][0]
    assert float(peak.get_ydata()[0]) == pytest.approx(k.max_gain(), rel=1e-9)
