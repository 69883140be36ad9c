"""Help text of the command line: every option states its form, no docstring markup.

:func:`finish` runs on the built parser (:func:`bridgeflap.design.cli.main.build_parser`): an option
without a metavar gets the one :data:`FORMS` gives its destination (``--speeds LO:HI:STEP``,
``--modes N``), an option without help the help there, and every text shown by ``--help`` loses its
Sphinx markup (roles such as ``:func:`x``` and double backticks, :func:`plain`).
``tests/test_design/cli/test_cli_help.py`` checks every command.
"""

from __future__ import annotations

import argparse
import re

__all__ = ["FORMS", "finish", "plain"]

_SPEEDS = "wind speeds [m/s]: LO:HI:STEP (HI included when on the grid) or a list V1,V2,..."
_FIGURE = "figure file (.png, .pdf or .svg)"

#: option destination -> (metavar, help when the option has none); ``(command, dest)`` keys
#: win over ``dest`` keys; the options of :data:`_SAME_EVERYWHERE` always take this help
FORMS: dict = {
    "speeds": ("LO:HI:STEP", _SPEEDS),
    "fractions": ("LO:HI:STEP", "erected fractions of the main span [-]: LO:HI:STEP or a "
                                "list F1,F2,..."),
    "modes": ("N", "retained vertical + torsional modes (an integer >= 1)"),
    "count": ("N", "modes listed (an integer >= 1)"),
    "workers": ("N", "worker processes (an integer >= 1)"),
    "samples": ("N", None), "records": ("N", None), "seed": ("N", None),
    "points": ("N", None), "lags": ("N", None), "flaps": ("N", None),
    "bridge": ("NAME|FILE.toml", None),
    "erection": ("FRACTION", None),
    "near_critical": ("FRACTION", None),
    "plot": ("FIGURE", _FIGURE),
    "controller": ("FILE.toml", None),
    "card": ("CARD|FILE.toml", None),
    "definition": ("FILE.toml", None),
    "file": ("FILE.toml", None),
    "out": ("DIR", "output folder"),
    ("state-space", "out"): ("FILE.npz|FILE.mat", "output file: .npz (numpy) or .mat (MATLAB)"),
    ("robustness", "out"): ("FILE.csv", None),
    ("actuators", "out"): ("FILE.csv", None),
    "speed": ("U", None), "speed_max": ("U", None), "target_m_s": ("U", None),
    "max_steps": ("N", None),
    "mass": ("KG_PER_M", None), "inertia": ("KGM2_PER_M", None),
    "f_heave": ("HZ", None), "f_torsion": ("HZ", None), "half_chord": ("M", None),
    "air_density": ("KG_PER_M3", None),
    "damping_ratio": ("ZETA", "structural damping ratio of both modes [-]"),
    "coherence_decay": ("C", None), "turbulence_intensity": ("I", None),
    "duration_s": ("SECONDS", None), "stuck_angle_deg": ("DEG", None),
    "flap_angle_limit_deg": ("DEG", None), "flap_rate_limit_deg_s": ("DEG_PER_S", None),
    "actuator_bandwidth_rad_s": ("RAD_PER_S", None),
    "margin_min": ("MARGIN", None),
    "objective": ("margin|critical_speed", None),
    "parameters": ("PATH,PATH,...", None),
    "scheduler": ("ADDRESS|serial", "Dask scheduler address, or 'serial' (default: a local "
                                    "cluster)"),
    "resume": (None, "reuse the finished cases of the folder"),
    "no_added_inertia": (None, "drop the apparent-inertia moment pi rho b^4 alpha''/8 "
                               "(Scanlan)"),
    "order": (None, "state-space order: modal (generalised coordinates) or full"),
    "rfa": (None, "rational approximation of Theodorsen's C(k)"),
    "name": (None, "rational approximation of Theodorsen's C(k) to report"),
    "aero": (None, "aerodynamic model of the section"),
    "spectrum": (None, "vertical turbulence spectrum"),
    "method": (None, "spectral (frequency domain) or monte-carlo (time-domain check)"),
}

#: options whose help is the same in every command (one grammar): this help and the default
_SAME_EVERYWHERE = ("speeds", "fractions")

_MARKUP = re.compile(r":[a-z]+:`~?([^`]*)`|``([^`]*)``")


def plain(text: str | None) -> str | None:
    """``text`` without Sphinx markup: ``:func:`x``` and ``x`` in double backticks -> ``x``."""
    if not text:
        return text
    return _MARKUP.sub(lambda m: m.group(1) if m.group(1) is not None else m.group(2), text)


def _options(parser: argparse.ArgumentParser):
    for action in parser._actions:
        if isinstance(action, argparse._HelpAction | argparse._VersionAction):
            continue
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                yield from ((name, a, sub) for a in _options(sub))
            continue
        yield "", action, parser


def finish(parser: argparse.ArgumentParser) -> argparse.ArgumentParser:
    """Fill metavars and missing help from :data:`FORMS`; strip markup from every text."""
    parser.description = plain(parser.description)
    parser.epilog = plain(parser.epilog)
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for choice in action._choices_actions:
                choice.help = plain(choice.help)
            for name, sub in action.choices.items():
                sub.description, sub.epilog = plain(sub.description), plain(sub.epilog)
                _finish_options(name, sub)
    _finish_options("", parser)
    return parser


#: the part of ``--bridge``'s help that holds only where the command takes ``--controller``
_CONTROLLER_CLAUSE = "; with --controller, the bridge the controller file was designed on"


def _finish_options(command: str, parser: argparse.ArgumentParser) -> None:
    has_controller = "--controller" in parser._option_string_actions
    for action in parser._actions:
        if action.dest == "bridge" and action.help and not has_controller:
            action.help = action.help.replace(_CONTROLLER_CLAUSE, "")
        if isinstance(action, argparse._HelpAction | argparse._VersionAction
                      | argparse._SubParsersAction):
            continue
        metavar, help_text = FORMS.get((command, action.dest), FORMS.get(action.dest,
                                                                         (None, None)))
        takes_value = action.nargs != 0
        if takes_value and action.metavar is None and action.choices is None and metavar:
            action.metavar = metavar
        if action.dest in _SAME_EVERYWHERE and action.option_strings:
            action.help = help_text + ("" if action.default is None else
                                       " (default: %(default)s)")
        if not action.help and help_text:
            action.help = help_text
        action.help = plain(action.help)
