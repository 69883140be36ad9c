"""``bridgeflap derivatives``: the flutter derivatives in use, their RFA fit and its error.

``--bridge`` takes a section case (``iabse-1.1a``, ``iabse-1.1c`` or a section ``.json`` file
with measured derivatives: :mod:`bridgeflap.model.cases.section_cases`) or a bridge of
:func:`bridgeflap.model.structure.loader.load_bridge` (Humber, a .toml), whose deck is a Theodorsen
flat plate of chord ``2 b`` (:func:`bridgeflap.model.aero.derivatives.flat_plate`, with the spec's
apparent-inertia convention). Prints the derivatives (Scanlan convention,
:mod:`bridgeflap.model.aero.derivatives`) over the data's reduced velocities, the Roger RFA (poles,
error per derivative) and, for a section case, its flutter speed by the RFA state space and by the
exact p-k against the reference. With ``--json`` one JSON object (numbers with units in the key
names, NaN as null); ``--plot FILE`` draws the derivatives and their fit against ``U / (f B)``. Bad
input: one line, exit 2.

Registration (integrator): ``Command("derivatives", HELP, cmd_derivatives.arguments,
cmd_derivatives.run)`` in :data:`bridgeflap.design.cli.main.COMMANDS`, or :func:`add_parser` on the
subparsers object. :func:`section_case_result` is the hook for ``flutter --bridge iabse-1.1a``:
its ``summary()`` has the keys of the Humber flutter summary (plus ``section_case``) and its
``plot()`` the sweep's figure (it lives here, not in model/, because it uses the facade's
``critical_speed``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bridgeflap.design.cli.common import (
    add_common,
    check_plot_target,
    emit,
    log,
    save_figure,
    speed_text,
)
from bridgeflap.model.errors import BridgeflapInputError

__all__ = ["SectionCaseResult", "add_parser", "arguments", "run", "section_case_result"]

HELP = "flutter derivatives in use and their RFA fit (error per derivative)"

#: most rows of the printed table (``--points``): a reduced-frequency table is read by eye and
#: the tabulated derivatives are smooth in K, so 10000 rows is far beyond any use; 1e8 rows
#: are 0.8 GB per derivative column before the JSON text
MAX_TABLE_POINTS = 10000

#: most lag poles of ``--lags``: the tables and the flat plate are fitted within their
#: accuracy by 2 to 4 lags (docs/methods.md), and every further lag is one more dimension of
#: the pole search (1000 lags ran for minutes before it was bounded)
MAX_LAGS = 10


def arguments(sp) -> None:
    """The options of ``bridgeflap derivatives``."""
    add_common(sp, erection=False)
    sp.add_argument("--lags", type=int, default=None,
                    help="lag poles of the Roger RFA (default 4 flat plate, 2 tables)")
    sp.add_argument("--added-inertia", choices=("kept", "dropped"), default=None,
                    help="flat plate: keep or drop the apparent-inertia moment (default: the "
                         "case's or the bridge file's convention)")
    sp.add_argument("--no-flutter", action="store_true",
                    help="section cases: skip the flutter speeds")
    sp.add_argument("--points", type=int, default=12, help="rows of the printed table")
    sp.add_argument("--plot", default=None, help="figure of the derivatives and fit")


def add_parser(sub):
    """Add the ``derivatives`` subcommand to an argparse subparsers object."""
    sp = sub.add_parser("derivatives", help=HELP)
    arguments(sp)
    sp.set_defaults(func=run)
    return sp


def _source(args):
    """``(name, derivatives, case or None)`` of ``--bridge``."""
    from bridgeflap.model.aero import derivatives as dv
    from bridgeflap.model.cases.section_cases import SECTION_CASES, load_section_case

    ai = None if args.added_inertia is None else args.added_inertia == "kept"
    if args.bridge in SECTION_CASES or str(args.bridge).lower().endswith(".json"):
        case = load_section_case(args.bridge, ai)
        return case.name, case.derivatives, case
    from bridgeflap.model.structure.loader import load_bridge

    spec = load_bridge(args.bridge)
    if getattr(spec, "derivatives", None) is not None:  # a modal bridge's derivative tables
        return spec.name, spec.derivatives.table(2 * spec.deck.half_chord_m), spec.derivatives
    keep = spec.aero.added_inertia if ai is None else ai
    return spec.name, dv.flat_plate(2 * spec.deck.half_chord_m, keep), None


def run(args):
    """Report the derivatives and the RFA of ``--bridge``."""
    from bridgeflap.model.aero.derivatives import DERIVATIVE_NAMES, convert_argument, fit_roger
    from bridgeflap.model.cases.section_cases import case_fit, section_case_flutter

    check_plot_target(args)
    if args.lags is not None and not 0 <= args.lags <= MAX_LAGS:
        raise BridgeflapInputError("lags", f"must be between 0 and {MAX_LAGS}, got {args.lags}")
    if not 2 <= args.points <= MAX_TABLE_POINTS:
        raise BridgeflapInputError("points", f"must be between 2 and {MAX_TABLE_POINTS}, got "
                                   f"{args.points}")
    name, src, case = _source(args)
    if hasattr(case, "fit_k_range"):  # [derivatives] of a modal bridge (modal_import)
        d = 3 if src.lateral and case.lateral else 2
        fit = case.fit(src.chord_m, d) if args.lags is None else fit_roger(
            src, n_lags=args.lags, n_dof=d, k_range=case.fit_k_range, weighting=case.weighting)
        case = None
    elif case is not None:
        fit = case_fit(case, args.lags)
    else:
        fit = fit_roger(src, n_lags=4 if args.lags is None else args.lags, k_range=(0.01, 6.0))
    lo, hi = src.k_range
    K = np.geomspace(max(lo, fit.k_fit.min()), hi, args.points)[::-1]
    table = src.values(K)
    fitted = fit.derivatives(K)
    used = [n for n in DERIVATIVE_NAMES if fit.errors.get(n) is not None]
    payload = {
        "bridge": name,
        "derivatives": src.name,
        "derivatives_source": src.source,
        "chord_m": src.chord_m,
        "convention": "Scanlan, K = B omega / U; h and L up, alpha and M nose-up, p and D "
                      "downwind (bridgeflap.model.aero.derivatives)",
        "table": {"reduced_velocity_hz": convert_argument(K, "K", "vred_hz").tolist(),
                  "reduced_frequency_K": K.tolist(),
                  **{n: np.asarray(table[n]).tolist() for n in used}},
        "rfa_fitted": {n: np.asarray(fitted[n]).tolist() for n in used},
        **fit.summary(),
    }
    lines = [f"{name}: {src.name} derivatives ({src.source}), B = {src.chord_m:g} m",
             f"Roger RFA: {fit.n_lags} lags, poles (s B/U) "
             + ", ".join(f"{g:.4g}" for g in fit.poles)
             + f", fit on K in [{fit.k_fit.min():.3g}, {fit.k_fit.max():.3g}]",
             "fit error per derivative (max |K^2 dX| / max |K^2 X|): "
             + ", ".join(f"{n} {fit.errors[n]:.2e}" for n in used),
             f"{'U/(fB)':>8s} " + " ".join(f"{n:>8s}" for n in used)]
    vr = convert_argument(K, "K", "vred_hz")
    for i in range(K.size):
        lines.append(f"{vr[i]:8.3f} " + " ".join(f"{table[n][i]:8.3f}" for n in used))
    if case is not None and not args.no_flutter:
        fl = section_case_flutter(case, n_lags=args.lags)
        keys = ("reference_flutter_speed_m_s", "reference_convention", "rfa_flutter_speed_m_s",
                "rfa_flutter_frequency_hz", "rfa_flutter_status", "rfa_relative_to_reference",
                "pk_flutter_speed_m_s", "pk_flutter_frequency_hz", "pk_flutter_status",
                "pk_relative_to_reference", "n_states")
        payload.update({k: fl[k] for k in keys})
        lines.append(f"flutter: RFA {speed_text(fl['rfa_flutter_speed_m_s'], 3)} at "
                     f"{_hz(fl['rfa_flutter_frequency_hz'])} [{fl['rfa_flutter_status']}], "
                     f"exact p-k {speed_text(fl['pk_flutter_speed_m_s'], 3)} at "
                     f"{_hz(fl['pk_flutter_frequency_hz'])} [{fl['pk_flutter_status']}]; "
                     f"reference {fl['reference_flutter_speed_m_s']:g} m/s "
                     f"({fl['reference_convention']})")
    if args.plot:
        _plot(src, fit, used, args.plot)
    emit(args, payload, "\n".join(lines))


def _plot(src, fit, used, path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from bridgeflap.model.aero.derivatives import convert_argument

    lo, hi = fit.k_fit.min(), fit.k_fit.max()
    K = np.geomspace(lo, hi, 300)
    vr = convert_argument(K, "K", "vred_hz")
    data, got = src.values(K), fit.derivatives(K)
    ncol = 6 if len(used) > 8 else 4
    nrow = int(np.ceil(len(used) / ncol))
    fig, axes = plt.subplots(nrow, ncol, figsize=(3.2 * ncol, 2.6 * nrow), layout="constrained",
                             squeeze=False)
    for ax, n in zip(axes.ravel(), used, strict=False):
        ax.plot(vr, data[n], "k-", lw=1.2, label="data")
        ax.plot(vr, got[n], "r--", lw=1, label="RFA")
        ax.set_title(f"{n}*  (err {fit.errors[n]:.1e})", fontsize=9)
        ax.set_xlabel("U / (f B)")
        ax.grid(alpha=0.3)
    for ax in axes.ravel()[len(used):]:
        ax.set_visible(False)
    axes.ravel()[0].legend(fontsize=7)
    fig.suptitle(f"{src.name}: Roger RFA, {fit.n_lags} lags")
    save_figure(fig, path)
    plt.close(fig)
    log(f"figure written: {path}")


@dataclass(frozen=True)
class SectionCaseResult:
    """Flutter of a section case in the shape of :class:`bridgeflap.model.analysis.FlutterResult`.

    ``summary()`` has the keys of the Humber ``flutter`` summary (the sweep of the Roger-RFA
    state space; ``critical_branch`` from the section's DOF labels) plus ``section_case``:
    the reference, the exact p-k on the derivatives and the RFA fit. ``plot()`` is the sweep's.
    """

    case: object
    sweep: object
    pk: object
    fit: object
    n_states: int

    def summary(self) -> dict:
        """JSON-ready numbers (units in the key names) and statuses."""
        from bridgeflap.model.analysis import critical_speed

        s = self.sweep.summary()
        label = self.sweep.critical_branch
        fam = {"heave": "vertical", "pitch": "torsional", "lateral": "lateral"}.get(label, "")
        s.update(critical_speed(s))
        ref = self.case.reference_speed_m_s
        pk = self.pk.flutter
        s.update({"bridge": self.case.name, "erected_fraction": 1.0, "joints_closed": True,
                  "critical_branch": {"label": label, "family": fam, "symmetry": "",
                                      "span": "", "frequency_hz": float("nan")},
                  "modes_retained": self.case.basis.n, "order": "modal", "rfa": self.fit.name,
                  "states": self.n_states, "half_chord_m": 0.5 * self.case.derivatives.chord_m,
                  "added_inertia": bool(getattr(self.case.derivatives, "added_inertia", False)),
                  "section_case": {
                      "derivatives": self.case.derivatives.name,
                      "reference_flutter_speed_m_s": ref,
                      "reference_convention": self.case.reference["convention"],
                      "pk_flutter_speed_m_s": pk.speed,
                      "pk_flutter_frequency_hz": pk.frequency_hz,
                      "pk_flutter_status": pk.status,
                      "rfa_relative_to_reference": (float(self.sweep.flutter.speed / ref - 1)
                                                    if np.isfinite(self.sweep.flutter.speed)
                                                    else float("nan")),
                      "pk_relative_to_reference": (float(pk.speed / ref - 1)
                                                   if np.isfinite(pk.speed) else float("nan")),
                      **self.fit.summary()}})
        return s

    def plot(self, axes=None):
        """Root locus, damping and frequency of the RFA sweep."""
        return self.sweep.plot(axes, title=self.case.name)


def section_case_result(name: str, speeds=None, added_inertia: bool | None = None,
                        n_lags: int | None = None) -> SectionCaseResult:
    """:class:`SectionCaseResult` of a built-in case (the hook for ``flutter --bridge NAME``).

    ``speeds`` [m/s] default ``0 .. 2 x reference`` in 401 points.
    """
    from bridgeflap.model.cases.section_cases import case_system, default_speeds, load_section_case
    from bridgeflap.model.stability import sweeps as stability

    case = load_section_case(name, added_inertia)
    if speeds is None:
        speeds = default_speeds(case)
    system, fit = case_system(case, n_lags)
    return SectionCaseResult(case, stability.sweep(system, speeds),
                             stability.pk_sweep(system, speeds), fit, system.n_states)


def _hz(f) -> str:
    """A frequency [Hz] for the text output (``None``/NaN: not found)."""
    return "-" if f is None or f != f else f"{f:.4f} Hz"
