"""The ``bridgeflap`` command line: an explicit table of commands (:data:`COMMANDS`).

Every command takes ``--json`` and then prints exactly one JSON object on stdout (numbers with
units in the key names, statuses; NaN as ``null``); progress and logs go to stderr. Bad input
gives one line ``bridgeflap: error: <field>: <reason>`` on stderr and exit status 2, with nothing
written (tests/test_bad_input.py holds the matrix). An internal fault (a bug: any exception that
is not a :class:`~bridgeflap.model.errors.BridgeflapError`) gives one line saying so and exit status
1; ``--debug`` (before or after the command) adds its traceback. Warnings are one line each.
Option defaults shared with studies and DOE files come from the registry
:data:`bridgeflap.design.studies.analyses.ANALYSES`.

Start-up stays lean: the command modules (``bridgeflap.design.cli.<name>``) load only when their
command runs (:func:`_later`), and only the chosen command's options are built
(:func:`build_parser`), so ``bridgeflap modes`` or ``flutter`` never import CasADi, matplotlib,
Dask, SALib, pandas or xarray (tests/test_startup.py checks ``sys.modules``).
"""

from __future__ import annotations

import argparse
import importlib
import os
import sys
import warnings
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from bridgeflap.design.cli.common import (
    Parser,
    add_common,
    add_verbosity,
    check_plot_target,
    check_writable_parent,
    controller_from_args,
    controller_report,
    default_bridge,
    emit,
    limit_text,
    log,
    save_plot,
    spec_from_args,
)
from bridgeflap.design.cli.help import finish
from bridgeflap.design.io.api_args import MAX_DESIGN_SPEED_M_S, MAX_SEED, MAX_VARIANTS
from bridgeflap.design.io.files import atomic_write
from bridgeflap.design.io.options import (
    MAX_GRID_VALUE,
    MAX_MODES,
    check_int,
    check_number,
    parse_range,
)
from bridgeflap.design.io.text import number_text, speed_text
from bridgeflap.design.studies.analyses import ANALYSES, DEFAULT_MODES, RunContext
from bridgeflap.model.aero.rfa import RFA_NAMES
from bridgeflap.model.arguments import MAX_WORKERS, argv_list, checked, optional
from bridgeflap.model.errors import BridgeflapInputError
from bridgeflap.model.results import table_text
from bridgeflap.model.structure.spec import SIDE_SPAN_SEQUENCES, check_fraction

__all__ = ["COMMANDS", "Command", "build_parser", "main"]

EXIT_BAD_INPUT = 2


# ------------------------------------------------------------------------------ commands


def cmd_modes(args):
    from bridgeflap.model.analysis import modal_model

    check_plot_target(args)
    spec = spec_from_args(args)
    if args.count < 1:
        raise BridgeflapInputError("count", "must be at least 1")
    modal = modal_model(spec)
    imported = getattr(spec, "structure", None) is not None  # imported modal data: all modes
    if args.count > len(modal.modes) and not imported:
        raise BridgeflapInputError("count", f"{args.count} requested, but this model has only "
                                            f"{len(modal.modes)} modes")
    modes = modal.mode_records()[: args.count]
    if imported:
        from bridgeflap.design.cli.imported import imported_modes

        return imported_modes(args, spec, modal, modes)
    payload = {"bridge": spec.name, "erected_fraction": spec.erected_fraction,
               "cable_horizontal_tension_n": modal.structure.statics.horizontal_tension_n,
               "cable_main_sag_m": modal.structure.statics.main_sag_m,
               "irvine_lambda_sq": modal.structure.statics.irvine_lambda_sq,
               "modes": modes}
    lines = [] if args.json else [  # the text table needs pandas: only when printed
        f"{spec.name}: erected fraction {spec.erected_fraction:.3f}, "
        f"H = {payload['cable_horizontal_tension_n'] / 1e6:.2f} MN per cable, "
        f"sag {payload['cable_main_sag_m']:.2f} m, lambda^2 = {payload['irvine_lambda_sq']:.1f}",
        table_text(modal.to_dataframe()[: args.count][
            ["label", "family", "symmetry", "frequency_hz", "damping_ratio",
             "main_span_share"]], "simple")]
    if args.plot:
        save_plot(modal, args.plot)
    emit(args, payload, "\n".join(lines))


def _run(name: str, spec, workers: int = 1, **options):
    """The result of registered analysis ``name``: the runner that studies and DOE cases use."""
    return _outcome(name, spec, workers, **options).result


def _outcome(name: str, spec, workers: int = 1, **options):
    """The whole :class:`~bridgeflap.design.studies.analyses.Outcome` of registered analysis
    ``name``."""
    entry = ANALYSES[name]
    context = RunContext(figures=False, progress=log, workers=workers)
    return entry.run(spec, {**entry.defaults, **options}, context)


def cmd_frequency_ratio(args):
    from bridgeflap.model.structure.loader import load_bridge

    check_plot_target(args)
    res = _run("frequency_ratio", load_bridge(args.bridge), fractions=args.fractions,
               side_spans=args.side_spans or "")
    lines = [f"side spans while erecting: {res.side_spans}",
             "erected  ratio(full GJ)  ratio(half GJ)  modes (half GJ)"]
    lines += [f"{s['erected_fraction']:7.3f}  {s['ratio_full_gj']:14.3f}  "
              f"{s['ratio_half_gj']:14.3f}  {s['torsional_mode']}/{s['vertical_mode']}"
              + ("  (hybrid: the deck mode is split between modes)"
                 if s["torsional_hybrid"] or s["vertical_hybrid"] else "")
              for s in res.stages]
    c = res.completed
    lines.append(f"completed bridge: {c['ratio']:.3f} ({c['torsional_mode']} {c['ts1_hz']:.4f} Hz"
                 f" / {c['vertical_mode']} {c['vs1_hz']:.4f} Hz)")
    if args.plot:
        save_plot(res, args.plot)
    emit(args, res.summary(), "\n".join(lines))


def _is_section_case(bridge: str) -> bool:
    """A section case (``iabse-1.1a``, ``iabse-1.1c``, a section ``.json``), not a bridge."""
    from bridgeflap.model.cases.section_cases import SECTION_CASES

    return bridge in SECTION_CASES or str(bridge).endswith(".json")


def _section_case_flutter(args):
    """``flutter --bridge iabse-1.1a``: the derivative state space and its exact p-k check."""
    if args.controller:
        raise BridgeflapInputError("controller", "a section case has no flaps")
    speeds = None if args.speeds == _default("flutter", "speeds") else \
        parse_range(args.speeds, "speeds", 0.0)
    from bridgeflap.design.cli import derivatives as cmd_derivatives

    res = cmd_derivatives.section_case_result(
        args.bridge, speeds, added_inertia=False if args.no_added_inertia else None)
    s = res.summary()
    text = (f"{args.bridge}: flutter {speed_text(s['flutter_speed_m_s'])} "
            f"[{s['flutter_status']}] (RFA state space), exact p-k "
            f"{speed_text(s['section_case']['pk_flutter_speed_m_s'])} "
            f"[{s['section_case']['pk_flutter_status']}]; reference "
            f"{s['section_case']['reference_flutter_speed_m_s']} m/s")
    if args.plot:
        save_plot(res, args.plot)
    emit(args, s, text)


def cmd_flutter(args):
    import dataclasses

    check_plot_target(args)
    if _is_section_case(args.bridge):
        return _section_case_flutter(args)
    spec = spec_from_args(args)
    if args.no_added_inertia:
        spec = dataclasses.replace(spec, aero=dataclasses.replace(spec.aero, added_inertia=False))
    if args.controller and (args.order, args.rfa) != ("modal", "rfa4"):
        raise BridgeflapInputError("controller", "the closed loop is built on the modal order "
                                                 "with rfa4: drop --order/--rfa")
    controller = controller_from_args(args, spec)
    if controller is not None:
        from bridgeflap.model.analysis import closed_loop_flutter

        res = closed_loop_flutter(spec, controller, parse_range(args.speeds, "speeds", 0.0),
                                  n_modes=args.modes, sweep_method=args.sweep or (
                                      "dense" if args.plot else _default("flutter", "sweep")))
    else:
        outcome = _outcome("flutter", spec, speeds=args.speeds, modes=args.modes,
                           order=args.order, rfa=args.rfa,
                           truncation_check=not args.no_truncation_check,
                           sweep=args.sweep or ("dense" if args.plot else
                                                _default("flutter", "sweep")))
        res = outcome.result
    s = {**(res.summary() if controller is not None else outcome.summary),
         **controller_report(controller)}
    if args.pk:
        from bridgeflap.model.analysis import pk_flutter

        pk = pk_flutter(spec, parse_range(args.speeds, "speeds", 0.0), args.modes, controller)
        s.update({f"pk_{k}": pk[k] for k in ("flutter_speed_m_s", "flutter_frequency_hz",
                                              "flutter_status", "critical_branch_label")})
    hz = number_text(s["flutter_frequency_hz"], ".4f", " Hz", none="")
    text = (f"{spec.name} (erected {spec.erected_fraction:.2f}, {s['modes_retained']} modes, "
            f"{s['order']} RFA {s['rfa']}, b = {spec.deck.half_chord_m} m)\n"
            f"flutter:    {limit_text(s, 'flutter')}"
            + (f" at {hz}" if hz else "")
            + f" [{s['flutter_status']}], critical branch "
            f"{s['critical_branch']['label'] or '-'}\n"
            f"divergence: {limit_text(s, 'divergence')} [{s['divergence_status']}]"
            f" (static check {speed_text(s['divergence_static_speed_m_s'])}"
            f" [{s.get('divergence_static_status', '')}])\n"
            f"governing:  {speed_text(s['critical_speed_m_s'])} ({s['critical_mechanism']})")
    if args.pk:
        text += (f"\nexact-Theodorsen p-k: flutter {speed_text(s['pk_flutter_speed_m_s'])} "
                 f"[{s['pk_flutter_status']}]")
    if s.get("truncation_status") == "all_modes_retained":
        text += f"\ntruncation: all {s['truncation_reference_modes']} modes of the model retained"
    elif "truncation_status" in s:
        text += (f"\ntruncation: flutter "
                 f"{number_text(s['flutter_truncation_error_pct'], '.3g', ' %')}, divergence "
                 f"{number_text(s['divergence_truncation_error_pct'], '.3g', ' %')} against "
                 f"{s['truncation_reference_modes']} modes [{s['truncation_status']}]")
    if args.plot:
        save_plot(res, args.plot)
    emit(args, s, text)


def cmd_state_space(args):
    from bridgeflap.model.aeroelastic.control_plant import closed_loop_plant, plant_data
    from bridgeflap.model.analysis import bridge_system

    spec = spec_from_args(args)
    if not (np.isfinite(args.speed) and args.speed >= 0):
        raise BridgeflapInputError("speed", f"must be a non-negative number, got {args.speed}")
    out = Path(args.out)
    if out.suffix.lower() not in (".npz", ".mat"):
        raise BridgeflapInputError("out", "must end in .npz or .mat")
    check_writable_parent("out", out)
    controller = controller_from_args(args, spec)
    if controller is not None and args.inputs == "gust":  # the package's closed loop
        plant = closed_loop_plant(spec, controller, args.speed, args.modes)
    else:  # open loop; a controller gives only its flap layout
        if getattr(spec, "derivatives", None) is not None:
            if args.inputs != "gust":
                raise BridgeflapInputError("inputs", "flap inputs need Theodorsen deck loads; a "
                                           "flutter-derivative bridge has no flap aerodynamics")
            if spec.static_coefficients is None:
                raise BridgeflapInputError("static_coefficients", "the gust inputs B of a "
                                           "flutter-derivative bridge are its quasi-steady loads")
        _, system = bridge_system(spec, args.modes)
        plant = plant_data(spec, args.speed, args.inputs, args.modes, controller=controller,
                           flaps=args.flaps, system=system)
    A, B, C = plant.A, plant.B, plant.C
    if out.suffix.lower() == ".npz":
        atomic_write(out, lambda fh: np.savez(fh, **plant.arrays()))
    else:
        import scipy.io

        atomic_write(out, lambda fh: scipy.io.savemat(fh, plant.arrays(mat=True)))
    payload = {"out": str(out), "input_set": args.inputs, "states": int(A.shape[0]),
               "inputs": int(B.shape[1]), "outputs": int(C.shape[0]),
               "wind_speed_m_s": args.speed,
               "spectral_abscissa_1_s": float(np.linalg.eigvals(A).real.max()),
               **controller_report(controller)}
    emit(args, payload, f"wrote {out}: {A.shape[0]} states, {B.shape[1]} inputs "
                        f"({args.inputs}), {C.shape[0]} outputs at U = {args.speed} m/s")


def cmd_rfa(args):
    from bridgeflap.model.aero.rfa import get_rfa

    rep = get_rfa(args.name).report()
    lines = [f"{rep['name']}: {rep['n_lags']} lags, C(s) = 1 - sum A_j s/(s + beta_j), s = i k",
             f"max |C_rfa - C| on 0 < k <= {rep['k_max']}: {rep['max_error']:.3e} "
             f"at k = {rep['k_at_max_error']:.4f}"]
    lines += [f"  A = {a:.8f}  beta = {p:.8f}" for a, p in zip(rep["gains"], rep["poles"],
                                                                 strict=True)]
    emit(args, rep, "\n".join(lines))


# ------------------------------------------------------------------------------ arguments


def _default(analysis: str, option: str):
    """The registry's default of ``option`` of ``analysis`` (shared with studies and DOEs)."""
    return ANALYSES[analysis].defaults[option]


def _modes_arguments(sp):
    add_common(sp)
    sp.add_argument("--count", type=int, default=_default("modes", "count"))
    sp.add_argument("--plot", default=None, help="mode-shape figure (.png/.pdf/.svg)")


_SIDE_SPANS_HELP = "side-span decks while erecting: bare, in_place, with_main (default: file's)"


def _frequency_ratio_arguments(sp):
    add_common(sp, erection=False)
    sp.add_argument("--fractions", default=_default("frequency_ratio", "fractions"))
    sp.add_argument("--side-spans", choices=SIDE_SPAN_SEQUENCES, default=None,
                    help=_SIDE_SPANS_HELP)
    sp.add_argument("--plot", default=None)


def _flutter_arguments(sp):
    add_common(sp)
    sp.add_argument("--speeds", default=_default("flutter", "speeds"),
                    help="start:stop:step [m/s]")
    sp.add_argument("--modes", type=int, default=_default("flutter", "modes"),
                    help="retained vertical+torsional modes")
    sp.add_argument("--order", choices=("modal", "full"), default=_default("flutter", "order"))
    sp.add_argument("--rfa", choices=RFA_NAMES, default=_default("flutter", "rfa"),
                    help="C(k) approximation: rfa4 (default), jones, rfa4-band "
                    "(bridgeflap.model.aero.rfa)")
    sp.add_argument("--controller", default=None, help="controller .toml (closed loop)")
    sp.add_argument("--sweep", choices=("dense", "fast"), default=None,
                    help="fast (default): coarse tracked sweep and Newton on the critical "
                         "eigenpairs, dense fallback when unsure; dense: eigenvalues at every "
                         "speed (the default with --plot: the figure needs every speed)")
    sp.add_argument("--pk", action="store_true",
                    help="also run the exact-Theodorsen p-k check on the same coordinates")
    sp.add_argument("--no-truncation-check", action="store_true",
                    help="skip the truncation-error estimate (a second sweep with 8 more modes)")
    sp.add_argument("--no-added-inertia", action="store_true",
                    help="drop the apparent-inertia moment pi rho b^4 alpha''/8 (Scanlan)")
    sp.add_argument("--plot", default=None)


def _state_space_arguments(sp):
    add_common(sp)
    sp.add_argument("--speed", type=float, required=True, help="[m/s]")
    sp.add_argument("--modes", type=int, default=DEFAULT_MODES)
    sp.add_argument("--controller", default=None,
                    help="with --inputs gust: its closed loop; else only its flap layout")
    sp.add_argument("--inputs", choices=("gust", "flaps", "both"), default="gust",
                    help="gust[i] strip gusts, flap_te[f]/flap_le[f] flap angles, or both")
    sp.add_argument("--flaps", type=int, default=5,
                    help="flaps side by side over the main span (flap inputs, no --controller)")
    sp.add_argument("--out", required=True)


def _rfa_arguments(sp):
    add_common(sp, bridge=False, erection=False)
    sp.add_argument("--name", choices=RFA_NAMES, default="rfa4")


# ------------------------------------------------------------------------------ table


@dataclass(frozen=True)
class Command:
    """One ``bridgeflap`` subcommand: its name, help line, arguments and function."""

    name: str
    help: str
    arguments: Callable[[argparse.ArgumentParser], None]
    run: Callable[[argparse.Namespace], None]


def _later(module: str, name: str) -> Callable:
    """``module.name``, imported when first called: a command's module loads only if it runs."""

    def call(*args, **kwargs):
        return getattr(importlib.import_module(module), name)(*args, **kwargs)

    call.__name__ = call.__qualname__ = name
    call.__module__ = module
    return call


#: every subcommand, in the order of ``bridgeflap --help``
COMMANDS: tuple[Command, ...] = (
    Command("modes", "structural modes", _modes_arguments, cmd_modes),
    Command("frequency-ratio", "f(TS1)/f(VS1) against erected fraction",
            _frequency_ratio_arguments, cmd_frequency_ratio),
    Command("flutter", "flutter and torsional divergence", _flutter_arguments, cmd_flutter),
    Command("erection", "flutter/divergence against erected fraction",
            _later("bridgeflap.design.cli.erection", "arguments"),
            _later("bridgeflap.design.cli.erection",
                                                                 "cmd_erection")),
    Command("section", "rigid 2-DOF deck section", _later("bridgeflap.design.cli.section",
                                                          "arguments"),
            _later("bridgeflap.design.cli.section", "cmd_section")),
    Command("state-space", "write A, B, C, D at one speed (.npz or .mat)",
            _state_space_arguments, cmd_state_space),
    Command("rfa", "fit report of the rational approximation of C(k)", _rfa_arguments, cmd_rfa),
    Command("derivatives", "flutter derivatives in use and their RFA fit (error per derivative)",
            _later("bridgeflap.design.cli.derivatives", "arguments"),
            _later("bridgeflap.design.cli.derivatives", "run")),
    Command("buffeting", "RMS deck response to vertical turbulence",
            *(_later("bridgeflap.design.cli.buffeting", f) for f in ("arguments",
                                                                     "cmd_buffeting"))),
    Command("optimise", "design the flap compensator (the paper, section 6)",
            *(_later("bridgeflap.design.cli.optimise", f) for f in ("arguments", "cmd_optimise"))),
    Command("placement", "the fewest flap strips, and where, that meet a target speed",
            *(_later("bridgeflap.design.cli.placement", f) for f in ("arguments",
                                                                     "cmd_placement"))),
    Command("study", "run a study (default: the paper's reproduction)",
            _later("bridgeflap.design.cli.study", "study_arguments"),
            _later("bridgeflap.design.cli.study", "cmd_study")),
    Command("doe", "design of experiments through the batch runner",
            _later("bridgeflap.design.cli.study", "doe_arguments"),
            _later("bridgeflap.design.cli.study", "cmd_doe")),
    Command("robustness", "do no harm: a controller on fresh variants, closed vs open loop",
            *(_later("bridgeflap.design.cli.robustness", f) for f in ("arguments",
                                                                      "cmd_robustness"))),
    Command("actuators", "flap angle/rate limits: the closed loop in turbulence (Monte Carlo)",
            *(_later("bridgeflap.design.cli.actuators", f) for f in ("arguments",
                                                                     "cmd_actuators"))),
    Command("sensitivity", "derivatives of flutter/divergence speed",
            _later("bridgeflap.design.cli.study", "sensitivity_arguments"),
            _later("bridgeflap.design.cli.study", "cmd_sensitivity")),
)


def _version_text() -> str:
    """``bridgeflap <version>`` of the installed distribution (a checkout: ``not installed``)."""
    from importlib.metadata import PackageNotFoundError, version

    try:
        return f"bridgeflap {version('bridgeflap')}"
    except PackageNotFoundError:
        return "bridgeflap (not installed: a source checkout)"


def build_parser(argv: list[str] | None = None) -> argparse.ArgumentParser:
    """The argument parser of :data:`COMMANDS` (also used for the README's command list).

    With ``argv``, only the options of the command it names are built (its module alone is
    imported); every other command is listed with its help line. Without, every command's.
    """
    chosen = None
    if argv is not None:
        names = {c.name for c in COMMANDS}
        chosen = next((a for a in argv if a in names), "")
    p = Parser(prog="bridgeflap", description="Aeroelastic design of long-span suspension bridges "
                                               "with active deck flaps (see the README)")
    p.add_argument("--debug", action="store_true",
                   help="on an internal fault, print the traceback (also after the command)")
    p.add_argument("--version", action="version", version=_version_text(),
                   help="print the package version and exit")
    add_verbosity(p)
    sub = p.add_subparsers(dest="command", parser_class=Parser)
    for command in COMMANDS:
        sp = sub.add_parser(command.name, help=command.help)
        if chosen is None or command.name == chosen:
            command.arguments(sp)
        sp.set_defaults(func=command.run)
    return finish(p)  # design.cli.help: each option's form, no docstring markup


def _limit_blas_threads() -> None:
    """Use one BLAS thread unless the user set ``OPENBLAS_NUM_THREADS``/``OMP_NUM_THREADS``.

    bridgeflap's dense matrices are small (at most a few hundred rows): multithreaded BLAS only
    adds synchronisation, and on a loaded 2-core machine it made ``eig`` up to 80x slower.
    Worker processes (DOE batches, multistart) inherit the setting through the environment.
    Called only by :func:`main`, the entry point: library code never sets the environment.
    """
    if any(v in os.environ for v in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS",
                                     "MKL_NUM_THREADS")):
        return
    for v in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ[v] = "1"
    from threadpoolctl import threadpool_limits

    threadpool_limits(1, user_api="blas")


#: (argument, minimum, maximum, integer) of every numeric option a command may take: checked
#: once after parsing (:func:`_check_args`), so every command refuses them alike, naming the
#: option and its limit, before any work
_NUMERIC_ARGS = (
    ("modes", 1, MAX_MODES, True),
    ("count", 1, 100000, True),
    ("records", 2, 10000, True),        # Monte-Carlo records (2 for a standard error)
    ("seed", 0, MAX_SEED, True),        # the API's bound (design.io.api_args)
    ("workers", 1, MAX_WORKERS, True),
    ("samples", 2, 4096, True),         # Morris trajectories / Sobol base sample
    ("speed", 0.0, MAX_GRID_VALUE, False),
    ("coherence_decay", 0.0, 1000.0, False),
    ("turbulence_intensity", 0.0, 1.0, False),
)

#: bounds of one command that differ from :data:`_NUMERIC_ARGS`' (the same option name for
#: another quantity): ``robustness --samples`` counts fresh variants, bounded as
#: ``do_no_harm(count=)`` and ``optimise --check-samples`` are; its ``--speed-max`` is a design
#: speed, bounded as ``do_no_harm(speed_max_m_s=)``
_COMMAND_ARGS = {
    "robustness": (("samples", 1, MAX_VARIANTS, True),
                   ("speed_max", 0.0, MAX_DESIGN_SPEED_M_S, False)),
}

#: plausible ranges of the rigid section's inputs (``bridgeflap section``): far outside any
#: deck, and small enough that ``m omega^2`` and the default speed grid stay finite
_SECTION_RANGES = (
    ("mass", 1e-3, 1e8), ("inertia", 1e-6, 1e12), ("f_heave", 1e-4, 100.0),
    ("f_torsion", 1e-4, 100.0), ("half_chord", 1e-3, 100.0), ("air_density", 1e-6, 100.0),
)


def _check_args(args) -> None:
    """Refuse out-of-range numeric options (one line naming the option and its limit)."""
    own = _COMMAND_ARGS.get(getattr(args, "command", None), ())
    table = {name: row for name, *row in (*_NUMERIC_ARGS, *own)}  # a command's own bound wins
    for name, (lo, hi, integer) in table.items():
        value = getattr(args, name, None)
        if value is None:
            continue
        option = "--" + name.replace("_", "-")
        if integer:
            check_int(value, option.lstrip("-"), lo, hi)
        elif name == "speed_max":
            check_number(value, option.lstrip("-"), lo, hi, strict=True)
        elif name == "turbulence_intensity":
            check_number(value, option.lstrip("-"), lo, hi, strict=True)
        else:
            check_number(value, option.lstrip("-"), lo, hi)
    if getattr(args, "global_method", None) == "sobol" and args.samples & (args.samples - 1):
        raise BridgeflapInputError("samples", f"the Sobol base sample must be a power of two, "
                                              f"got {args.samples}")
    if getattr(args, "command", None) == "section":
        for name, lo, hi in _SECTION_RANGES:
            option = name.replace("_", "-")
            value = check_number(getattr(args, name), option, 0.0, hi, strict=True)
            if value < lo:
                raise BridgeflapInputError(option, f"must be at least {lo:g}, got {value:g}")
        check_number(args.damping_ratio, "damping-ratio", 0.0, 0.999)
    if getattr(args, "erection", None) is not None:
        check_fraction(args.erection)
    if isinstance(getattr(args, "speeds", None), str):
        parse_range(args.speeds, "speeds", 0.0)
    if isinstance(getattr(args, "fractions", None), str):
        for f in parse_range(args.fractions, "fractions"):
            check_fraction(f)
    check_plot_target(args)
    for name in ("controller",):
        path = getattr(args, name, None)
        if path is not None and not Path(path).is_file():
            raise BridgeflapInputError(name, f"not a file: {path}")
    if hasattr(args, "bridge"):  # the default --bridge: design.cli.common.default_bridge
        args.bridge = default_bridge(args)


@checked(argv=optional(argv_list))
def main(argv=None) -> int:
    """Entry point of the ``bridgeflap`` console script (:func:`bridgeflap.design.cli.run.run`).

    Exit status: 0 success; 1 a result that is not usable (the command says why), or an
    internal fault (one line saying it is a bug; the traceback only with ``--debug``);
    2 bad input (one line ``bridgeflap: error: <field>: <reason>``, nothing written; also
    what the OS refuses, and a bare ``bridgeflap``: a short usage); 130 interrupted (Ctrl-C:
    one line, temporaries removed).

    Parameters
    ----------
    argv : list of str, optional
        The arguments (default: ``sys.argv[1:]``), e.g. ``["flutter", "--json"]``.

    Returns
    -------
    int
        The exit status above.

    Examples
    --------
    >>> from bridgeflap import design
    >>> design.main(["--version"])  # doctest: +SKIP
    bridgeflap ...
    0
    """
    from bridgeflap.design.cli.run import one_line_warning, run

    _limit_blas_threads()
    console = argv is None  # the console script: its process ends with the command
    argv = sys.argv[1:] if argv is None else [str(a) for a in argv]
    debug = "--debug" in argv
    with warnings.catch_warnings():
        if not debug:
            warnings.showwarning = one_line_warning
        return run(argv, debug, build_parser=build_parser, check_args=_check_args,
                   command_names=[c.name for c in COMMANDS], bounded_interrupt=console)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
