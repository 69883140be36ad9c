"""How ``bridgeflap`` runs one command and ends (:func:`bridgeflap.design.cli.main.main` calls
:func:`run`).

* **Exit statuses.** 0 success; 1 a result that is not usable, or an internal fault (one line
  saying it is a bug; its traceback only with ``--debug``); 2 bad input, including what the OS
  refuses (no space, no permission, a read-only file system, a name too long: one line naming
  the option, the path and the reason, :func:`bridgeflap.design.cli.common.os_error_as_input`); 130
  interrupted.
* **One line for a refusal.** Warning and note lines (``bridgeflap: warning: ...``) are held
  back until the command shows progress, prints its result or ends
  (:func:`bridgeflap.design.cli.common.log`); a refused input drops them, so it prints its error
  line only.
* **Ctrl-C, SIGTERM.** While a command runs, SIGINT (and SIGTERM alike, exit status 143)
  raises :class:`KeyboardInterrupt` once in this
  process (every ``finally`` then removes its temporaries and releases its lock) and ends as
  the one line ``bridgeflap: interrupted``, exit status 130; a second Ctrl-C during that
  clean-up ends the process at once. Worker processes forked meanwhile (process pools) end
  silently on SIGINT (its default action, restored in the child right after the fork), and
  a local Dask cluster's workers ignore it
  (:data:`bridgeflap.design.batch.cluster.LOCAL_WORKER_CONFIG`): the cluster is closed by this
  process. So a terminal's Ctrl-C, which signals the whole process group, prints no worker's
  traceback.
* **A bound on the clean-up.** Run as the console script, the command ends at the latest
  :data:`INTERRUPT_GRACE_S` after the first Ctrl-C or SIGTERM, whatever it is waiting for: a
  watchdog thread then kills the worker processes still alive, prints the one line (unless it
  was printed) and ends the process with the same status. A clean-up takes well under a second;
  the bound is for a pool left waiting by a signal that came in the middle of starting a worker.
  What such an ending leaves behind (a run lock, a temporary folder) is removed by the next run
  into that folder (:func:`bridgeflap.design.io.outputs.recover_output`).
"""

from __future__ import annotations

import multiprocessing
import os
import signal
import sys
import threading
import time

from bridgeflap.design.cli.common import (
    drop_warnings,
    hold_warnings,
    log,
    os_error_as_input,
    release_warnings,
    set_verbosity,
)
from bridgeflap.model.errors import BatchFailedError, BridgeflapError
from bridgeflap.model.workers import clear_interrupt, note_interrupt

__all__ = ["BUG_REPORT", "EXIT_BAD_INPUT", "EXIT_INTERNAL", "EXIT_INTERRUPTED", "run"]

EXIT_INTERNAL = 1
EXIT_BAD_INPUT = 2
EXIT_INTERRUPTED = 130
INTERRUPTED = "bridgeflap: interrupted"

#: the one line printed for an internal fault (anything but a BridgeflapError)
BUG_REPORT = ("this is a bug in bridgeflap, not in your input; please report it to the bridgeflap "
              "maintainers with the command line and the traceback of --debug")

_STATE = {"pid": None, "interrupted": False, "caught": False, "timers": [], "said": False,
          "watchdog": None}

#: seconds from the first Ctrl-C or SIGTERM to the forced end of a console-script run whose
#: clean-up waits on something that will not come (the watchdog of the module docstring); a
#: clean-up takes well under a second, a local Dask cluster's close a few seconds
INTERRUPT_GRACE_S = 30.0


def _on_sigint(signum, frame):
    """SIGINT (or SIGTERM) while a command runs: :class:`KeyboardInterrupt`; during the
    clean-up after it (once :func:`run` has caught it), end at once."""
    status = 128 + int(signum) if signum == signal.SIGTERM else EXIT_INTERRUPTED
    if os.getpid() != _STATE["pid"]:  # a forked child that kept the handler: end quietly
        os._exit(status)
    if _STATE["caught"]:  # a second signal while cleaning up
        os.write(2, (INTERRUPTED + "\n").encode())
        os._exit(status)
    _STATE["interrupted"] = True
    _STATE["status"] = status
    if _STATE["watchdog"] is not None:  # a write to a pipe: safe in a signal handler
        try:
            os.write(_STATE["watchdog"], b"i")
        except OSError:
            pass
    note_interrupt()
    raise KeyboardInterrupt


def _start_watchdog() -> int:
    """A daemon thread that ends this process :data:`INTERRUPT_GRACE_S` after it reads ``i``
    from the pipe whose write end is returned (:func:`_on_sigint` writes it)."""
    read_end, write_end = os.pipe()
    pid = os.getpid()

    def watch() -> None:
        try:
            if os.read(read_end, 1) != b"i":
                return
        except OSError:
            return
        time.sleep(INTERRUPT_GRACE_S)
        if os.getpid() != pid:
            return
        for child in multiprocessing.active_children():
            try:
                child.kill()
            except (OSError, AttributeError):
                pass
        if not _STATE["said"]:
            os.write(2, (INTERRUPTED + "\n").encode())
        os._exit(_STATE.get("status", EXIT_INTERRUPTED))

    threading.Thread(target=watch, name="bridgeflap-interrupt-watchdog", daemon=True).start()
    return write_end


def _unraisable(hook):
    """A ``sys.unraisablehook`` that raises a lost Ctrl-C again: a KeyboardInterrupt raised
    where Python ignores exceptions (a fork hook, a finaliser) would let the command run on."""

    def unraisable(info):
        if (issubclass(info.exc_type, KeyboardInterrupt) and os.getpid() == _STATE["pid"]
                and not _STATE["caught"]):
            # signalled again from another thread, so that it is raised outside this hook
            timer = threading.Timer(0.05, _signal_again)
            timer.daemon = True
            _STATE["timers"].append(timer)
            timer.start()
            return
        hook(info)

    return unraisable


def _signal_again() -> None:
    """SIGINT to this process again, unless the command has ended or been caught (a late
    signal would meet the interpreter's shutdown: "Exception ignored in threading")."""
    if _STATE["pid"] == os.getpid() and not _STATE["caught"]:
        os.kill(os.getpid(), signal.SIGINT)


def _child_after_fork() -> None:
    """In a process forked while a command runs (a pool worker): SIGINT's default action, so
    that Ctrl-C ends it at once and silently, even inside a long call into C."""
    if _STATE["pid"] is not None and os.getpid() != _STATE["pid"]:
        try:
            signal.signal(signal.SIGINT, signal.SIG_DFL)
            signal.signal(signal.SIGTERM, signal.SIG_DFL)
        except (ValueError, OSError):  # not the main thread: _on_sigint ends it instead
            pass


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_child_after_fork)


def run(argv: list[str], debug: bool, *, build_parser, check_args, command_names,
        bounded_interrupt: bool = False) -> int:
    """Parse ``argv``, run its command and return the exit status (see the module doc).

    The command table comes in as arguments (``bridgeflap.design.cli.main`` passes its
    ``build_parser``, its argument checks and its command names), so that this module does not
    import the CLI back. ``bounded_interrupt``: the console script's run, whose process ends at
    the latest :data:`INTERRUPT_GRACE_S` after an interrupt (never for a call from Python,
    whose process goes on)."""
    main_thread = threading.current_thread() is threading.main_thread()
    previous = signal.signal(signal.SIGINT, _on_sigint) if main_thread else None
    previous_term = signal.signal(signal.SIGTERM, _on_sigint) if main_thread else None
    _STATE.update(pid=os.getpid(), interrupted=False, caught=False, status=EXIT_INTERRUPTED,
                  said=False,
                  watchdog=_start_watchdog() if (bounded_interrupt and main_thread) else None)
    hook, sys.unraisablehook = sys.unraisablehook, _unraisable(sys.unraisablehook)
    hold_warnings()
    try:
        return _run(argv, debug, build_parser, check_args, command_names)
    except KeyboardInterrupt:  # raised again during the clean-up of an error
        return _interrupted()
    finally:
        release_warnings(hold=False)
        if not bounded_interrupt:  # called from Python: later pools of this process wait again
            clear_interrupt()
        if _STATE["watchdog"] is not None and not _STATE["interrupted"]:
            os.write(_STATE["watchdog"], b"q")  # no interrupt: the watchdog ends
            os.close(_STATE["watchdog"])
            _STATE["watchdog"] = None
        _STATE["pid"] = None
        for timer in _STATE["timers"]:  # a pending re-signal of a lost Ctrl-C: not any more
            timer.cancel()
        _STATE["timers"].clear()
        sys.unraisablehook = hook
        if main_thread:
            signal.signal(signal.SIGINT, previous)
            signal.signal(signal.SIGTERM, previous_term)


def _run(argv: list[str], debug: bool, build_parser, check_args, command_names) -> int:
    args = None
    try:
        parser = build_parser(argv)
        args = parser.parse_args(argv)
        if not getattr(args, "command", None):
            drop_warnings()
            sys.stderr.write(short_usage(command_names))
            return EXIT_BAD_INPUT
        set_verbosity(getattr(args, "quiet", False), getattr(args, "verbose", False))
        check_args(args)
        rc = args.func(args)
    except KeyboardInterrupt:
        return _interrupted()
    except BatchFailedError as exc:  # input accepted, every case failed: no usable result
        return _end(f"bridgeflap: error: {_one_line(str(exc))}", 1)
    except BridgeflapError as exc:  # BridgeflapInputError included
        drop_warnings()
        return _end(f"bridgeflap: error: {_one_line(str(exc))}", EXIT_BAD_INPUT)
    except OSError as exc:  # a path the user gave that the OS refuses: bad input, not a bug
        bad = os_error_as_input(exc, args)
        if _STATE["interrupted"]:
            return _interrupted()
        if bad is None:
            return _internal(exc, debug)
        drop_warnings()
        return _end(f"bridgeflap: error: {_one_line(str(bad))}", EXIT_BAD_INPUT)
    except Exception as exc:  # the last line of defence: one line, exit 1
        if _STATE["interrupted"]:  # e.g. a pool broken by the workers Ctrl-C ended
            return _interrupted()
        return _internal(exc, debug)
    release_warnings()
    return int(rc or 0)  # a command may report a result that is not usable (exit 1)


def _end(line: str, status: int) -> int:
    release_warnings()
    log(line)
    return status


def _interrupted() -> int:
    _STATE["caught"] = True
    drop_warnings()
    log(INTERRUPTED)
    _STATE["said"] = True
    return _STATE.get("status", EXIT_INTERRUPTED)


def short_usage(command_names) -> str:
    """What a bare ``bridgeflap`` prints: the usage line, the commands, where to read more."""
    names = list(command_names)
    half = (len(names) + 1) // 2
    return ("usage: bridgeflap [--debug] COMMAND [options]\n"
            f"commands: {', '.join(names[:half])},\n"
            f"          {', '.join(names[half:])}\n"
            "see bridgeflap --help, or bridgeflap COMMAND --help\n")


def _internal(exc: BaseException, debug: bool) -> int:
    """An internal fault: one line saying it is a bug (the traceback with ``--debug``)."""
    release_warnings()
    if debug:
        import traceback

        traceback.print_exception(exc, file=sys.stderr)
    log(f"bridgeflap: internal error: {type(exc).__name__}: {_one_line(str(exc))[:300]}; "
        f"{BUG_REPORT if not debug else 'traceback above'}")
    return EXIT_INTERNAL


def _one_line(text: str) -> str:
    """``text`` with its line breaks folded, so that an error stays one line."""
    return " ".join(text.split())


def one_line_warning(message, category, filename, lineno, file=None, line=None) -> None:
    """Show a warning as one line on stderr (no source line; ``--debug`` keeps Python's)."""
    log(f"bridgeflap: warning: {category.__name__}: {_one_line(str(message))}")
