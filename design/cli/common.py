"""What every ``bridgeflap`` command shares: the parser, common options, output and figures.

Every command takes ``--json`` and then prints exactly one JSON object on stdout (numbers with
units in the key names, statuses; NaN as ``null``); progress and logs go to stderr. Bad input
raises :class:`~bridgeflap.model.errors.BridgeflapInputError`, which
:func:`bridgeflap.design.cli.main.main` turns into one line on stderr and exit status 2.
"""

from __future__ import annotations

import argparse
import errno
import json
import logging
import os
import sys
from pathlib import Path

from bridgeflap.design.io.files import atomic_write, to_jsonable
from bridgeflap.design.io.text import speed_text
from bridgeflap.model.errors import BridgeflapInputError

__all__ = ["Parser", "add_common", "check_plot_target", "check_writable_parent",
           "controller_from_args", "controller_report", "default_bridge", "default_workers",
           "drop_warnings", "emit", "hold_warnings", "limit_text",
           "log", "LOGGER", "os_error_as_input", "release_warnings", "set_verbosity",
           "save_figure", "save_plot", "spec_from_args", "speed_text"]

FIGURE_SUFFIXES = (".png", ".pdf", ".svg")


class Parser(argparse.ArgumentParser):
    """Argument parser whose errors are one line and exit status 2."""

    def error(self, message):  # noqa: D102 - argparse API
        raise BridgeflapInputError("arguments", message)


def add_common(sp: argparse.ArgumentParser, bridge: bool = True, erection: bool = True) -> None:
    """``--json``, and ``--bridge`` / ``--erection`` where the command takes a bridge."""
    sp.add_argument("--json", action="store_true", help="print one JSON object on stdout")
    # also accepted after the command; SUPPRESS keeps the top-level value (design.cli.main.main)
    sp.add_argument("--debug", action="store_true", default=argparse.SUPPRESS,
                    help="on an internal fault, print the traceback")
    if bridge:
        sp.add_argument("--bridge", default=None,
                        help="built-in name such as humber or humber:box, or path to a bridge "
                             ".toml (default: humber; with --controller, the bridge the "
                             "controller file was designed on)")
    if erection:
        sp.add_argument("--erection", type=float, default=None,
                        help="erected fraction of the main span in (0, 1]")
    add_verbosity(sp, argparse.SUPPRESS)


def add_verbosity(parser: argparse.ArgumentParser, default=False) -> None:
    """``--quiet`` / ``--verbose`` (before or after the command, as ``--debug``)."""
    parser.add_argument("--quiet", action="store_true", default=default,
                        help="no progress lines on stderr (warnings and errors still shown)")
    parser.add_argument("--verbose", action="store_true", default=default,
                        help="also the debug lines of the 'bridgeflap' logger on stderr")


def default_workers() -> int:
    """Worker processes a command uses by default: ``min(2, CPU count)`` (the project's
    target machine has 2 cores; ``--workers`` says otherwise)."""
    return max(1, min(2, os.cpu_count() or 1))


def emit(args, payload: dict, text: str) -> None:
    """Print ``payload`` as one JSON object with ``--json``, else ``text`` (held warnings
    first, on stderr)."""
    release_warnings()
    if getattr(args, "json", False):
        sys.stdout.write(json.dumps(to_jsonable(payload), allow_nan=False) + "\n")
    else:
        sys.stdout.write(text.rstrip("\n") + "\n")


#: warning and note lines held back while a command runs (:func:`hold_warnings`)
_HELD: dict = {"pid": None, "lines": []}
_HELD_PREFIXES = ("bridgeflap: warning:", "bridgeflap: note:")


#: the command line's logger: progress lines at INFO, warning and note lines at WARNING, each
#: written as it is to stderr (:func:`log`; ``--quiet`` / ``--verbose``, :func:`set_verbosity`)
LOGGER = logging.getLogger("bridgeflap")


class _StderrHandler(logging.Handler):
    """Each record's message, one line, on the current ``sys.stderr`` (looked up per line, so a
    redirected stderr, e.g. pytest's capture, receives it)."""

    def emit(self, record):  # noqa: D102 - logging API
        sys.stderr.write(record.getMessage() + "\n")
        sys.stderr.flush()


def _logger() -> logging.Logger:
    if not any(isinstance(h, _StderrHandler) for h in LOGGER.handlers):
        LOGGER.addHandler(_StderrHandler())
        LOGGER.propagate = False
        if LOGGER.level == logging.NOTSET:
            LOGGER.setLevel(logging.INFO)
    return LOGGER


def set_verbosity(quiet: bool = False, verbose: bool = False) -> None:
    """``--quiet``: warnings and errors only; ``--verbose``: debug lines too; else progress."""
    _logger().setLevel(logging.WARNING if quiet else logging.DEBUG if verbose else logging.INFO)


#: lines that ``--quiet`` never hides: a refusal, an internal fault, an interruption
_ERROR_PREFIXES = ("bridgeflap: error:", "bridgeflap: internal error:", "bridgeflap: interrupted")


def _level(msg: str) -> int:
    if msg.startswith(_ERROR_PREFIXES):
        return logging.ERROR
    return logging.WARNING if msg.startswith(_HELD_PREFIXES) else logging.INFO


def log(msg: str) -> None:
    """One line of progress on stderr (the ``bridgeflap`` logger). While :func:`hold_warnings`
    is on, a warning or note line waits until the next other line (or
    :func:`release_warnings`): a refusal that follows drops it (:func:`drop_warnings`), so a
    refused input prints one line only."""
    if _HELD["pid"] == os.getpid() and msg.startswith(_HELD_PREFIXES):
        _HELD["lines"].append(msg)
        return
    release_warnings()
    _logger().log(_level(msg), msg)


def hold_warnings() -> None:
    """Hold warning and note lines back from now on, in this process (:func:`log`)."""
    _HELD.update(pid=os.getpid(), lines=[])


def release_warnings(hold: bool = True) -> None:
    """Print the held warning lines; with ``hold=False`` also stop holding."""
    lines, _HELD["lines"] = _HELD["lines"], []
    if not hold:
        _HELD["pid"] = None
    for line in lines:
        _logger().log(_level(line), line)


def drop_warnings() -> None:
    """Forget the held warning lines (a refusal follows: its line says what matters)."""
    _HELD["lines"] = []


def default_bridge(args) -> str:
    """``--bridge`` when given; else the bridge a ``--controller`` file records (its plant
    record, variant included: a design on ``humber:box`` is re-checked there, said in one
    note line); else ``humber``."""
    if getattr(args, "bridge", None) is not None:
        return args.bridge
    path = getattr(args, "controller", None)
    if path:
        from bridgeflap.model.aeroelastic.controller_file import load_controller

        plant = load_controller(path).plant
        if plant is not None:
            bridge = plant.bridge + (f":{plant.bridge_variant}" if plant.bridge_variant else "")
            if bridge != "humber":  # the built-in default needs no word
                log(f"bridgeflap: note: --bridge {bridge} (the bridge {path} was designed on)")
            return bridge
    return "humber"


def spec_from_args(args):
    """The bridge of ``--bridge``, erected to ``--erection`` when given."""
    from bridgeflap.model.structure.loader import load_bridge

    spec = load_bridge(args.bridge)
    if getattr(args, "erection", None) is not None:
        spec = spec.erected(args.erection)
    return spec


def controller_from_args(args, spec=None):
    """The controller of ``--controller`` (a .toml), or ``None``.

    A controller whose peak gain exceeds its own ``gain_limit`` is used (the user asked for
    it), with one warning line on stderr; :func:`controller_report` gives the flag for the
    JSON. Its flap geometry (chord, width, positions, edges) is the file's; a file designed on
    another bridge, or without a geometry record, gives one warning line on stderr, and flaps
    that do not fit on ``--bridge`` raise naming the field
    (:func:`bridgeflap.model.aeroelastic.controller_file.check_controller_plant`; ``spec``: the
    bridge of ``--bridge`` when already loaded).
    """
    if getattr(args, "controller", None):
        from bridgeflap.model.aeroelastic.controller_file import load_controller

        controller = load_controller(args.controller)
        bridge = getattr(args, "bridge", None)
        if bridge is not None:
            from bridgeflap.model.aeroelastic.controller_file import check_controller_plant

            if spec is None:
                from bridgeflap.model.structure.loader import load_bridge

                spec = load_bridge(bridge)
            note = check_controller_plant(controller, bridge, spec)
            if note:  # an old file is read as before: a note, not a warning
                kind = "note" if controller.plant is None else "warning"
                log(f"bridgeflap: {kind}: controller {args.controller}: {note}")
        check = controller.gain_check()
        if not check["controller_within_gain_limit"]:
            log(f"bridgeflap: warning: controller {args.controller}: max gain "
                f"{check['controller_max_gain']:.4g} exceeds its gain limit "
                f"{check['controller_gain_limit']:.4g} (controller_within_gain_limit: false)")
        return controller
    return None


def controller_report(controller) -> dict:
    """``controller_max_gain``, ``controller_gain_limit`` and ``controller_within_gain_limit``
    of ``controller`` (empty for ``None``), for a command's JSON."""
    return {} if controller is None else controller.gain_check()


def _short(path) -> str:
    """``path`` for a message: a long one cut in the middle (a 300-character name stays short)."""
    s = os.fspath(path)
    return s if len(s) <= 120 else f"{s[:60]}...{s[-50:]}"


#: what the file system or the OS refuses for want of room, rights or a usable name: bad
#: input or environment (one line, exit status 2), even without a file name to show
OS_REFUSALS = frozenset(getattr(errno, n) for n in (
    "ENOSPC", "EDQUOT", "EROFS", "EACCES", "EPERM", "ENAMETOOLONG", "ENOENT", "ENOTDIR",
    "EISDIR", "EEXIST", "ENOTEMPTY", "EXDEV", "EMFILE", "ENFILE", "EFBIG", "ELOOP")
    if hasattr(errno, n))


def os_error_as_input(exc: OSError, args=None) -> BridgeflapInputError | None:
    """A file-system refusal of a path the user gave ("File name too long", "Permission
    denied", "No space left on device", ...) as bad input: the option whose value the path is
    (or lies in, or holds, or is a temporary or backup sibling of) named when ``args`` shows
    it, else ``path``; ``None`` for an OSError that names no file and is no such refusal (not
    about a path the user gave)."""
    if exc.filename is None:
        if exc.errno not in OS_REFUSALS:
            return None
        return BridgeflapInputError("path", exc.strerror or os.strerror(exc.errno))
    path = os.path.abspath(os.fspath(exc.filename))
    field = "path"
    for key, value in sorted(vars(args).items()) if args is not None else ():
        if isinstance(value, str | os.PathLike) and os.fspath(value) and key != "command":
            v = os.path.abspath(os.fspath(value))
            sibling = os.path.join(os.path.dirname(v), f".{os.path.basename(v)}.")
            if (path == v or path.startswith(v + os.sep) or v.startswith(path + os.sep)
                    or path.startswith(sibling)):
                field = key.replace("_", "-")
                break
    return BridgeflapInputError(field, f"{_short(exc.filename)}: {exc.strerror or exc}")


def check_writable_parent(field: str, path: Path) -> None:
    """Raise unless ``path``'s folder exists and is writable and ``path`` is not a folder."""
    parent = path.parent if str(path.parent) else Path(".")
    try:
        if not parent.is_dir() or not os.access(parent, os.W_OK):
            raise BridgeflapInputError(field, f"folder missing or not writable: {parent}")
        if path.is_dir():
            raise BridgeflapInputError(field, f"is a folder, not a file: {path}")
    except OSError as exc:  # e.g. a component beyond the file system's NAME_MAX
        raise BridgeflapInputError(field, f"{_short(path)}: {exc.strerror or exc}") from None


def check_output_folder(field: str, path: Path) -> None:
    """Raise unless ``path``'s parent folder exists and is writable and ``path`` is not a file
    (the output folder of ``optimise`` and ``placement``; what is in it:
    :func:`bridgeflap.design.io.outputs.check_replaceable`)."""
    parent = path.resolve().parent
    if not parent.is_dir():
        raise BridgeflapInputError(field, f"parent folder does not exist: {parent}")
    if not os.access(parent, os.W_OK):
        raise BridgeflapInputError(field, f"folder not writable: {parent}")
    if path.exists() and not path.is_dir():
        raise BridgeflapInputError(field, f"is a file, not a folder: {path}")


def _check_figure_path(path: Path) -> None:
    if path.suffix.lower() not in FIGURE_SUFFIXES:
        raise BridgeflapInputError("plot", f"unsupported figure type {path.suffix!r} "
                                           "(use .png, .pdf or .svg)")
    check_writable_parent("plot", path)


def check_plot_target(args) -> None:
    """Check ``--plot`` before any work, so that bad input writes nothing."""
    if getattr(args, "plot", None):
        _check_figure_path(Path(args.plot))


def save_figure(fig, path: str | Path) -> Path:
    """Save a matplotlib figure atomically (temp file in the same folder, then rename)."""
    path = Path(path)
    _check_figure_path(path)
    return atomic_write(path, lambda fh: fig.savefig(fh, format=path.suffix[1:].lower(), dpi=130,
                                                     bbox_inches="tight"))


def save_plot(result, path) -> None:
    """``result.plot()`` saved to ``path`` (first figure when it returns several axes)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from bridgeflap.model.results import figure_of

    fig = figure_of(result.plot())  # a Figure (results), or axes (older plotting helpers)
    save_figure(fig, path)
    plt.close(fig)
    log(f"figure written: {path}")


def limit_text(s: dict, mech: str) -> str:
    """A flutter/divergence speed for the text output, or where the grid starts unstable."""
    first = s.get(f"{mech}_unstable_from_m_s")
    return (speed_text(s[f"{mech}_speed_m_s"]) if first is None
            else f"unstable already at the first speed, {first:.2f} m/s")
