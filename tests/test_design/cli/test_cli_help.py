"""``bridgeflap <command> --help``: every option says its form, no markup.

Pure text checks of the built parser and of the ``bridgeflap`` logger (no physics runs, so no
numerical tolerances).
"""

from __future__ import annotations

import argparse
import logging
import re

import pytest

from bridgeflap.design.cli.common import LOGGER, log, set_verbosity
from bridgeflap.design.cli.main import COMMANDS, build_parser

#: Sphinx roles (``:func:`x```), double backticks and reST substitutions
MARKUP = re.compile(r":[a-z]+:`|``|\|[a-z]+\|")


def _subparsers():
    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return parser, sub.choices


def test_top_level_help_has_no_markup():
    parser, _ = _subparsers()
    text = parser.format_help()
    assert not MARKUP.search(text), MARKUP.search(text)
    assert "--quiet" in text and "--verbose" in text and "--version" in text


@pytest.mark.parametrize("name", [c.name for c in COMMANDS])
def test_every_option_has_help_stating_its_form(name):
    _, subs = _subparsers()
    sp = subs[name]
    text = sp.format_help()
    assert not MARKUP.search(text), f"{name}: {MARKUP.search(text)}"
    for action in sp._actions:
        if isinstance(action, argparse._HelpAction):
            continue
        label = "/".join(action.option_strings) or action.dest
        assert action.help and action.help.strip(), f"{name} {label}: no help"
        if action.nargs != 0:  # takes a value: its form is a metavar or the choices
            assert action.metavar or action.choices, f"{name} {label}: no form"
    for action in sp._actions:
        if action.dest == "speeds":  # one speed grammar on every command
            assert action.metavar == "LO:HI:STEP" and "[m/s]" in action.help


def test_progress_goes_through_the_bridgeflap_logger(capsys):
    assert LOGGER is logging.getLogger("bridgeflap")
    try:
        log("step 1 of 2 ...")
        assert capsys.readouterr().err == "step 1 of 2 ...\n"  # the text is unchanged
        set_verbosity(quiet=True)
        log("step 2 of 2 ...")
        log("bridgeflap: warning: x: shown even when quiet")
        assert capsys.readouterr().err == "bridgeflap: warning: x: shown even when quiet\n"
    finally:
        set_verbosity()
    log("again")
    assert capsys.readouterr().err == "again\n"
