"""The study report: ``report.md`` and ``report.html`` comparing a study with the paper.

:func:`study_document` builds one :class:`bridgeflap.design.studies.document.Document` (Table 1, the
65/74 m/s speeds, Figs. 2-5, the flap compensator and the sensitivities) from a
:class:`bridgeflap.design.studies.study.StudyResult`: every number in it is read from the result
summaries that the study writes to ``results/<analysis>.json``, formatted once, and rendered both as
Markdown (:func:`study_report`, tables by pandas/tabulate) and as a self-contained HTML file with
the figures inline (:func:`study_report_html`). :func:`fig5` draws the paper's Fig. 5: the
closed-loop root locus over the open loop and the vertical and torsional buffeting with and
without flaps.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

# the figure is drawn by the design analysis; also here
from bridgeflap.design.studies.analyses import fig5
from bridgeflap.design.studies.document import Document

if TYPE_CHECKING:
    from bridgeflap.design.studies.study import StudyResult

__all__ = ["PAPER", "fig5", "study_document", "study_report", "study_report_html"]

#: the paper's complete-bridge speeds [m/s]
PAPER = {"flutter_speed_m_s": 65.0, "divergence_speed_m_s": 74.0}


def _fmt(x, spec=".2f") -> str:
    if x is None or isinstance(x, bool) or not isinstance(x, int | float) or not np.isfinite(x):
        return "-"
    return format(x, spec)


def _modes(x, n, spec=".2f") -> str:
    """A number with the mode count of the model it comes from, ``69.50 (16 modes)``: two
    models of one bridge (the study's flutter analysis, the design's verification model) give
    slightly different speeds, which the report must not show as one quantity."""
    text = _fmt(x, spec)
    return text if text == "-" or n in (None, "") else f"{text} ({n} modes)"


def _pct(x, ref) -> str:
    if x is None or not isinstance(x, int | float) or not np.isfinite(x) or not ref:
        return "-"
    return f"{100 * (x - ref) / ref:+.1f} %"


_CAPTIONS = {
    "frequency_ratio": ("Fig. 2", "f(TS1)/f(VS1) against deck completion with half and full GJ "
                        "(the completed bridge as its own marker), and the deck modes the "
                        "ratio rule picks. Same construction as the paper (EI = 0, GJ halved "
                        "while erecting); differences come from our estimated deck inertia and "
                        "the paper's unknown mode pairing at small fractions."),
    "flutter": ("Fig. 3 (left)", "Root locus (both axes in 1/s, frequency in Hz on the right, "
                "rays of constant damping ratio), V-g and V-f of every tracked branch on axes "
                "that hold all the data, and the flutter mode along the span (heave and pitch "
                "amplitude and phase). As in the paper TS1 softens and couples with the "
                "vertical modes."),
    "erection": ("Fig. 3 (right)", "Flutter and divergence against deck completion; the "
                 "completed bridge (joints closed) is its own marker at 100 %. The paper "
                 "compares with Brancaleoni's findings, which we do not have as numbers."),
    "buffeting": ("Fig. 4", "Vertical RMS [mm] (over 2b, the paper's ordinate, on the right "
                  "axis) and torsional RMS [deg] against wind speed. The "
                  "measured curve of the paper's ref. [6] is not available as numbers, so only "
                  "our curve is shown."),
    "design": ("Fig. 5", "Closed loop with the optimised flap compensator: root locus 0-85 m/s "
               "over the open loop (grey), vertical and torsional buffeting with and without "
               "flaps and the design's own open-loop flutter speed; then the margins per speed "
               "(spectral abscissa, smallest damping ratio, robust margin) with the flap layout "
               "on the deck, and the Bode plot of K(s) in Hz with the gain limit."),
    "sensitivity": ("(extra)", "Tornado of relative derivatives (p/U) dU/dp by the "
                    "implicit-function theorem, checked by finite differences."),
    "modes": ("(extra)", "Mode shapes of the complete bridge, one panel per family, towers "
              "dotted."),
}


def study_document(res: StudyResult, figures: dict) -> Document:
    """The report of a finished study (``figures``: analysis -> figure files, relative to the
    output folder), as a :class:`~bridgeflap.design.studies.document.Document`."""
    cfg, r = res.config, res.results
    doc = Document()
    doc.heading(1, f"Study `{cfg.name}`: reproduction of Massaro, Limebeer et al. (flutter and "
                   "buffeting of long-span suspension bridges)")
    from bridgeflap.design.io.identity import bridge_label

    doc.paragraph(f"Bridge: `{bridge_label(cfg.bridge)}`; quick mode: {cfg.quick}"
                  + (f" (mesh {cfg.element_length_m} m)" if cfg.element_length_m else "")
                  + f"; run time {res.elapsed_s:.1f} s. Inputs marked NOT FOUND/ESTIMATE in "
                    "docs/humber_data.md (sag, cable spacing, deck inertia, half-chord; EI/GJ "
                    "updated to Table 1) are the built-in estimates; none was tuned to the "
                    "paper's speeds.")
    if "design" in r:     # the controller's verdict first: harm is never a footnote
        doc.paragraph(_design_verdict(r["design"]))
    doc.heading(2, "Solver and analysis statuses")
    doc.table(list(res.statuses.items()), ["analysis", "status"])
    solver = _solver_lines(r)
    if solver:
        doc.paragraph("Solver statuses inside the analyses:")
        doc.items(solver)
    if "modes" in r and "table1" in r["modes"]:
        _table1(doc, r["modes"])
    if "flutter" in r and "flutter_speed_m_s" in r["flutter"]:
        _flutter_section(doc, r["flutter"])
    if "design" in r and isinstance(r["design"].get("coefficients"), dict):
        _design_section(doc, r["design"])
    doc.heading(2, "Figures")
    for kind in res.statuses:
        fig_no, text = _CAPTIONS.get(kind, ("", ""))
        names = figures.get(kind, [])
        doc.heading(3, f"{fig_no}: {kind}")
        if not names:
            doc.paragraph(f"No figure: {res.statuses[kind]}.")
        for k, n in enumerate(names):
            doc.figure(n, text if k == len(names) - 1 else "", alt=kind)
    if "sensitivity" in r and "derivatives" in r["sensitivity"]:
        doc.heading(2, "Sensitivities (implicit-function theorem)")
        doc.table([(p, _fmt(d.get("value_si"), ".4g"),
                    _fmt(d.get("d_flutter_speed_m_s_per_unit"), ".4g"),
                    _fmt(d.get("d_flutter_speed_m_s_per_unit_fd"), ".4g"),
                    _fmt(d.get("relative_d_flutter_speed"), "+.3f"),
                    _fmt(d.get("relative_d_divergence_speed"), "+.3f"),
                    _kink_cell(d),
                    f"{d.get('flutter_status')}/{d.get('divergence_status')}")
                   for p, d in r["sensitivity"]["derivatives"].items()],
                  ["parameter", "value", "dU_F/dp (IFT)", "full FD", "(p/U_F) dU_F/dp",
                   "(p/U_D) dU_D/dp", "kink: one-sided (p/U) dU/dp", "status"])
        n = r["sensitivity"].get("modes_retained")
        step = (r["sensitivity"].get("settings") or {}).get("rel_step_kink")
        doc.paragraph(f"Derivatives of the {n}-mode model. kink: the derivative does not "
                      "describe the speed over "
                      + (f"±{100 * step:g} %" if step else "a few per cent")
                      + " of the input (the critical branch changes, or a one-sided slope "
                        "leaves the derivative by more than 0.02 + 0.25 of it); the cell gives "
                        "the one-sided relative slopes, minus side / plus side.")
    return doc


def _kink_cell(d: dict) -> str:
    """The sensitivity table's kink cell: ``-`` when not flagged, else each flagged speed with
    its one-sided relative slopes (``UF -0.173/+0.087``); empty when not assessed."""
    if d.get("kink") is None:
        return ""
    cells = [f"{m} {_fmt(d.get(f'relative_d_{q}_speed_minus'), '+.3f')}/"
             f"{_fmt(d.get(f'relative_d_{q}_speed_plus'), '+.3f')}"
             for q, m in (("flutter", "UF"), ("divergence", "UD")) if d.get(f"{q}_kink")]
    return "; ".join(cells) or "-"


def study_report(res: StudyResult, figures: dict) -> str:
    """The Markdown report (``report.md``) of a finished study."""
    return study_document(res, figures).markdown()


def study_report_html(res: StudyResult, figures: dict, folder) -> str:
    """The self-contained HTML report (``report.html``); figures read from ``folder``."""
    return study_document(res, figures).html(folder, title=f"bridgeflap study {res.config.name}")


def _solver_lines(r) -> list[str]:
    solver = []
    if "flutter" in r and "flutter_status" in r["flutter"]:
        solver.append(f"flutter sweep: flutter `{r['flutter']['flutter_status']}`, divergence "
                      f"`{r['flutter']['divergence_status']}`")
    if "erection" in r and "stages" in r["erection"]:
        for st in r["erection"]["stages"]:
            solver.append(f"erection {st['erected_fraction']:.2f}: flutter "
                          f"`{st.get('flutter_status')}`, divergence "
                          f"`{st.get('divergence_status')}`")
    if "sensitivity" in r and "derivatives" in r["sensitivity"]:
        solver.append(f"sensitivity nominal: flutter `{r['sensitivity']['flutter_status']}`, "
                      f"divergence `{r['sensitivity']['divergence_status']}`")
    for kind in ("buffeting", "design"):
        if kind in r:
            inner = r[kind].get("solver_status")
            solver.append(f"{kind}: `{r[kind]['status']}`"
                          + (f" (solver statuses: {', '.join(map(str, inner))})"
                             if isinstance(inner, list) else ""))
    return solver


def _table1(doc: Document, modes: dict) -> None:
    doc.heading(2, "Table 1: natural frequencies")
    doc.paragraph("Measured (Brownjohn et al. 1994) and the paper's model, against ours (paired "
                  "in frequency order within each family, main-span modes; see "
                  "model/cases/validation.py).")
    doc.table([(row["family"], row["table1_label"], _fmt(row["measured_hz"], ".3f"),
                _fmt(row["seed_model_hz"], ".3f"), _fmt(row["bridgeflap_hz"], ".3f"),
                row["bridgeflap_label"], _fmt(row["difference_percent"], "+.1f"))
               for row in modes["table1"]],
              ["family", "Table 1 label", "measured [Hz]", "paper model [Hz]", "ours [Hz]",
               "our label", "ours vs measured [%]"])
    doc.paragraph("EI, GJ and lateral EI were fitted (least RMS log-misfit) to these measured "
                  "frequencies (runs/model_updating), so the family-wide agreement is partly by "
                  "construction; the individual mode pairings are the test. Table 1's labels "
                  "are partly inconsistent (two VA rows, VS below VA).")


def _flutter_section(doc: Document, f: dict) -> None:
    uf, ud = f["flutter_speed_m_s"], f["divergence_speed_m_s"]
    n = f.get("modes_retained")
    doc.heading(2, "Flutter and torsional divergence (complete bridge)")
    doc.table([("flutter speed [m/s]", "65", _modes(uf, n), _pct(uf, 65.0), f["flutter_status"]),
               ("flutter frequency [Hz]", "-", _modes(f["flutter_frequency_hz"], n, ".4f"), "-",
                f["flutter_status"]),
               ("torsional divergence [m/s]", "74", _modes(ud, n), _pct(ud, 74.0),
                f["divergence_status"])],
              ["quantity", "paper", "ours", "difference", "status"])
    crit = (f.get("critical_branch") or {}).get("label") or f.get("critical_branch_label")
    doc.paragraph(f"Critical branch {crit or '-'}; participation "
                  + ", ".join(f"{k} {v:.2f}" for k, v in f["critical_participation"].items())
                  + f"; {f['modes_retained']} modes, RFA {f['rfa']}, b = {f['half_chord_m']} m.")
    doc.paragraph(f"Governing speed {_fmt(f.get('critical_speed_m_s'))} m/s "
                  f"({f.get('critical_mechanism', '-')}, {n} modes). Divergence depends only "
                  "on GJ, the cable torsional stiffness 2H(b_c/2)^2 and the aerodynamic moment "
                  f"(rho U^2 b^2), so it scales close to 1/b with the half-chord b = "
                  f"{f['half_chord_m']} m, which the paper does not state; flutter also depends "
                  "on the updated TS1/VS1 frequencies (`python runs/humber_inputs/run.py` shows "
                  "both for each reading of b and of the deck mass).")
    if f.get("truncation_status") == "converged":
        doc.paragraph(f"Truncation error against {f['truncation_reference_modes']} modes: "
                      f"flutter {_fmt(f['flutter_truncation_error_pct'], '.2g')} %, divergence "
                      f"{_fmt(f['divergence_truncation_error_pct'], '.2g')} % "
                      "(bridgeflap.model.stability.convergence).")
    elif f.get("truncation_status"):
        doc.paragraph(f"Truncation check: {f['truncation_status']}.")
    doc.paragraph(f"Flutter onset {f.get('flutter_onset', '-')} (dζ/dU = "
                  f"{_fmt(f.get('flutter_damping_slope_s_per_m'), '.2e')} s/m); second-critical "
                  f"branch {f.get('second_critical_branch_label') or '-'} "
                  f"({f.get('second_flutter_status', '-')}, "
                  f"{_fmt(f.get('second_flutter_speed_m_s'))} m/s).")
    doc.paragraph(f"Every speed of this section is of the {n}-mode model. Other models of "
                  "the bridge (the flap design's, for one) state their own mode count beside "
                  "each speed: more modes move the speeds slightly (the truncation error "
                  "above), so two such numbers are not the same quantity.")


def _pc(x, spec=".2f") -> str:
    """A fraction as a percentage (``-`` when absent)."""
    return _fmt(None if x is None else 100.0 * x, spec)


def _design_verdict(d: dict) -> str:
    """One paragraph: the designed controller's status and its acceptance verdict."""
    acc = d.get("acceptance") or {}
    rob = acc.get("robustness") or {}
    st = d.get("status")
    usable = st == "converged" and acc.get("status") in ("passed", "not_run", None)
    head = (f"**Controller: {st}, usable.**" if usable else
            f"**Controller: {st}, NOT usable (no controller file written).**")
    use = d.get("usable_speed_m_s")
    if use is not None or d.get("open_loop_critical_speed_m_s") is not None:
        # the speed it is usable to with its real actuators, first, beside the open loop's
        head = (f"**Usable speed {_fmt(use, '.1f')} m/s** (limited by "
                f"{d.get('usable_speed_limited_by') or '-'}) against the open-loop critical "
                f"speed {_fmt(d.get('open_loop_critical_speed_m_s'), '.2f')} m/s; linear "
                f"closed-loop critical speed (ideal actuators) "
                f"{_fmt(d.get('linear_closed_loop_critical_speed_m_s'), '.2f')} m/s. " + head)
    parts = [f"Acceptance: {acc.get('status', 'not_run')}"
             + (f" ({acc['reason']})" if acc.get("reason") else "")]
    if "variants" in rob:
        parts.append(f"do no harm on {rob['variants']} fresh variants: "
                     f"{rob.get('harmed_count', '?')} harmed (95 % upper bound on the harm "
                     f"probability {_pc(rob.get('harm_probability_upper_95'))} %), "
                     f"worst closed/open {_fmt(rob.get('worst_closed_over_open'), '.3f')}, "
                     f"{_pc(rob.get('fraction_stable_to_design_speed'), '.1f')}"
                     f" % stable to {_fmt(rob.get('design_speed_m_s'), 'g')} m/s")
    lim = d.get("closed_loop_limits") or {}
    if lim.get("critical_speed_m_s") is not None:
        modes = f", {lim['modes']} modes" if lim.get("modes") else ""
        parts.append(f"nominal linear closed-loop critical speed (ideal actuators) "
                     f"{_fmt(lim.get('critical_speed_m_s'), '.2f')} m/s "
                     f"({lim.get('critical_mechanism', '-')}{modes})")
    return f"{head} " + "; ".join(parts) + "."


def acceptance_rows(text: str) -> list[tuple[str, str]]:
    """``(check, result)`` rows of the acceptance text; a line without the ``check: result``
    form (the verdict's meaning) is a row of its own."""
    rows = []
    for line in text.splitlines():
        head, sep, rest = line.strip().partition(":")
        rows.append((head, rest.strip()) if sep else ("", line.strip()))
    return rows


def _response_table(doc: Document, d: dict) -> None:
    """The paper's Fig. 5 (right) as numbers: open- and closed-loop RMS heave and twist and the 3
    sigma flap demand by speed, the actuator limits marked (``response_by_speed``)."""
    rows = d.get("response_by_speed") or []
    if not rows:
        return
    use = d.get("usable_speed_m_s")
    doc.paragraph(f"Deck response and flap demand by speed (the paper's Fig. 5 right as numbers; "
                  f"spectral, the design turbulence, max RMS on the main span; the actuator "
                  f"limits are {rows[0]['flap_angle_limit_deg']:g} deg and "
                  f"{rows[0]['flap_rate_limit_deg_s']:g} deg/s; **beyond limit**: the 3 sigma "
                  f"demand passes it; usable speed {_fmt(use, '.1f')} m/s):")

    def deg(x):
        return None if x is None else float(np.degrees(x))

    doc.table([(f"{r['speed_m_s']:g}", _fmt(r["open_loop_rms_heave_m"], ".3g"),
                _fmt(r["closed_loop_rms_heave_m"], ".3g"),
                _fmt(deg(r["open_loop_rms_twist_rad"]), ".3g"),
                _fmt(deg(r["closed_loop_rms_twist_rad"]), ".3g"),
                _fmt(r["flap_angle_3sigma_deg"], ".3g"), _fmt(r["flap_rate_3sigma_deg_s"], ".3g"),
                "within" if r["within_actuator_limits"] else "**beyond limit**")
               for r in rows],
              ["U [m/s]", "heave, open loop [m]", "heave, closed loop [m]",
               "twist, open loop [deg]", "twist, closed loop [deg]", "3σ flap angle [deg]",
               "3σ flap rate [deg/s]", "actuators"])


def _design_section(doc: Document, d: dict) -> None:
    """The flap-compensator design (the paper, §6, Fig. 5)."""
    c = d["coefficients"]
    doc.heading(2, "Flap compensator (the paper, §6, Fig. 5)")
    doc.paragraph(f"Controller file: `{d.get('controller_file', '-')}` (use it with "
                  "`bridgeflap flutter|buffeting|state-space --controller`).")
    doc.paragraph(f"Designed on bridge `{d.get('settings', {}).get('bridge', '-')}` (the "
                  "study's [design] table says why when it differs from the study's bridge).")
    doc.paragraph(f"K(s) = ({_fmt(c['b2'], '.4g')} s^2 {_fmt(c['b1'], '+.4g')} s "
                  f"{_fmt(c['b0'], '+.4g')}) / ({_fmt(c['a2'], '.4g')} s^2 "
                  f"{_fmt(c['a1'], '+.4g')} s + 1), driving {d.get('flap_count')} LE+TE flap "
                  "pairs from the local deck pitch (LE and TE antisymmetric).")
    ver = d.get("verification") or {}
    rows = [("design status", d.get("status")),
            ("max gain, sup over w of abs K(jw)",
             f"{_fmt(d.get('max_gain'), '.3f')} (limit {d.get('gain_limit')})"),
            (f"closed loop stable to [m/s] (dense {ver.get('modes', '-')}-mode check)",
             _fmt(d.get("closed_loop_stable_to_m_s"), ".2f")),
            ("robust margin 1 / max norm(T, inf) over the speed grid",
             f"{_fmt(d.get('robust_margin'), '.4f')} at "
             f"{_fmt(d.get('robust_margin_worst_speed_m_s'), '.2f')} m/s "
             f"({_fmt(d.get('robust_margin_at_robust_speeds'), '.4f')} at the robust speeds)"),
            ("minimum flap count (same K)", (d.get("minimum_flaps") or {}).get("minimum")),
            (f"min damping ratio of the movable branches (required "
             f"{_fmt(d.get('zeta_min'), '.3f')})", _fmt(ver.get("min_damping_ratio"), ".4f"))]
    lim = d.get("closed_loop_limits") or {}
    if "governing_speed_m_s" in lim:
        n = lim.get("modes")  # the verification model's (closed_loop_limits)
        with_n = f", {n} modes" if n else ""
        rows += [(f"closed-loop flutter [m/s] ({lim.get('flutter_status')})",
                  f"{_fmt(lim.get('flutter_speed_m_s'), '.2f')} at "
                  f"{_fmt(lim.get('flutter_frequency_hz'), '.3f')} Hz" + with_n),
                 (f"closed-loop divergence [m/s] ({lim.get('divergence_status')}; static "
                  "check)", f"{_fmt(lim.get('divergence_speed_m_s'), '.2f')} "
                            f"({_fmt(lim.get('divergence_static_speed_m_s'), '.2f')}{with_n})"),
                 ("governing closed-loop limit [m/s]",
                  f"{_fmt(lim.get('governing_speed_m_s'), '.2f')} "
                  f"({lim.get('governing_mechanism')}{with_n})"),
                 ("open-loop flutter of the design model [m/s]",
                  _modes(lim.get("open_loop_flutter_speed_m_s"), n)),
                 ("open-loop divergence of the design model [m/s]",
                  _modes(lim.get("open_loop_divergence_speed_m_s"), n))]
    act = d.get("active_constraints") or {}
    if act:
        rows.append(("active at the optimum",
                     f"damping at {act.get('nlp_active_damping_speeds_m_s') or act.get('damping_speeds_m_s')}"  # noqa: E501
                     f" m/s; gain limit {act.get('gain_limit')}; bounds "
                     f"{act.get('coefficient_bounds')}; objective bound "
                     f"{act.get('objective_bound')}"))
    rows += [("optimisation wall time [s]", _fmt(d.get("wall_time_s"), ".1f")),
             ("analysis time incl. the Fig. 5 sweeps [s]", _fmt(d.get("elapsed_s"), ".1f"))]
    doc.table(rows, ["quantity", "value"])
    t_inf = d.get("robust_T_inf_by_speed") or {}
    if t_inf:
        doc.paragraph("Robust margin per speed (1 / sup over w of sigma_max(T(jw))):")
        doc.table([(u, _fmt(1.0 / t if t else None, ".3f"), _fmt(t, ".3f"))
                   for u, t in t_inf.items()], ["U [m/s]", "margin [-]", "norm(T, inf) [-]"])
    starts = d.get("starts") or []
    if starts:
        doc.paragraph("Every Ipopt start (ranked by the NLP objective among the verified "
                      "ones; margin at the robust speeds):")
        doc.table([(st.get("start"), st.get("status"), st.get("iterations"),
                    _fmt(st.get("time_s"), ".1f"), _fmt(st.get("objective"), ".5g"),
                    _fmt(st.get("max_gain"), ".3f"),
                    _fmt(st.get("robust_margin"), ".3f"), st.get("stable_everywhere"),
                    st.get("verified"))
                   for st in starts],
                  ["start", "Ipopt status", "iterations", "time [s]", "objective", "max gain",
                   "margin", "stable to the design speed", "verified"])
    acc = d.get("acceptance") or {}
    if acc.get("checks"):
        from bridgeflap.design.assessment.acceptance import acceptance_text

        doc.paragraph("Acceptance checks of the controller (as `bridgeflap optimise` runs "
                      "them; bridgeflap.design.assessment.acceptance):")
        doc.table(acceptance_rows(acceptance_text(acc)), ["check", "result"])
    _response_table(doc, d)
    buf = d.get("buffeting") or {}
    if buf.get("speeds_m_s"):
        doc.paragraph("Buffeting, open vs closed loop (max RMS on the main span):")
        tor_o = buf.get("open_loop_rms_torsion_rad") or [None] * len(buf["speeds_m_s"])
        tor_c = buf.get("closed_loop_rms_torsion_rad") or [None] * len(buf["speeds_m_s"])
        def mm(x):  # [m] -> [mm]
            return None if x is None else 1000.0 * x

        def deg(x):  # [rad] -> [deg]
            return None if x is None else float(np.degrees(x))

        doc.table([(f"{u:g}", _fmt(mm(o), ".1f"), _fmt(mm(cl), ".1f"), _pct(cl, o),
                    _fmt(deg(to), ".3g"), _fmt(deg(tc), ".3g"), _pct(tc, to))
                   for u, o, cl, to, tc in zip(buf["speeds_m_s"], buf["open_loop_rms_vertical_m"],
                                               buf["closed_loop_rms_vertical_m"], tor_o, tor_c,
                                               strict=False)],
                  ["U [m/s]", "vertical, open loop [mm]", "vertical, closed loop [mm]",
                   "vertical change", "torsion, open loop [deg]", "torsion, closed loop [deg]",
                   "torsion change"])
    doc.paragraph("The paper hand-tunes one compensator and shows its root locus; here Ipopt "
                  "maximises the robust margin subject to a minimum damping ratio of every "
                  "branch the flaps can move at every design speed and the gain limit, and the "
                  "result is verified on a dense grid.")
