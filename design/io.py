"""Output folders and atomic, self-describing output files.

Every file a run writes goes through this module so that an interrupted run never leaves a
half-written file behind: the data are written to a temporary file in the *same* folder
(``.<name>.<random>.tmp``), flushed and ``fsync``-ed, and then moved over the target with
:func:`os.replace`, which is atomic on POSIX and Windows when source and target are on the same
file system. A reader therefore sees either the old file or the complete new one.

Output *folders* (``study``, ``doe``, batch folders) follow four rules, all here:

* **Ownership.** Every folder a run writes carries the marker file :data:`OUTPUT_MARKER`
  (``.bridgeflap-output``, a JSON tag ``{"tool": "bridgeflap", "kind", "version", "pid",
  "host", "created_utc"}``). A run replaces or reuses only a folder that is missing, empty or
  marked; an existing non-empty folder without the marker (a user's own files) is refused
  with :class:`~model.errors.BridgeflapInputError` naming ``out``, before anything is written
  (:func:`check_replaceable`).
* **One run at a time.** :func:`claim_output` takes a non-blocking :mod:`filelock` lock on
  ``.<name>.lock`` *next to* the folder (never inside the folder being replaced); a second run
  into the same folder is refused at once. The lock file is left in place after the run (on
  POSIX, deleting a lock file while others may open it would let two runs hold "the" lock).
* **Crash-safe replace.** :func:`swap_into_place` renames the previous folder to a backup
  ``.<name>.old-<pid>-<random>``, renames the complete new folder to the target, then deletes
  the backup. A kill between the two renames leaves no target but a complete, marked backup:
  the next run into that folder (under the lock, so no live run is mid-swap) renames the
  backup back first (:func:`recover_output`), then proceeds. A kill after the second rename
  leaves a stale backup next to the new folder, deleted at the next run. (A symlink swap would
  make the replace atomic for readers but turns every output folder into a link, which users
  copy and archive badly; the rename pair plus recovery keeps plain folders.)
* **Stale temporaries.** Temporary folders ``.<name>.tmp-<random>`` carry the marker with the
  writer's pid; the next run deletes those whose process is gone (same host only).

JSON output is strict (RFC 8259): NaN and +-inf have no JSON spelling, so :func:`to_jsonable`
turns them into ``null``. A ``null`` number in a result file therefore means "not a finite
number" (failed solve, no flutter in the range, ...); the status field next to it says why.
"""

from __future__ import annotations

import contextlib
import dataclasses
import datetime as _dt
import enum
import json
import math
import os
import shutil
import signal
import socket
import sys
import tempfile
import uuid
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any, BinaryIO

import numpy as np

from model.errors import BridgeflapInputError

__all__ = [
    "OUTPUT_MARKER",
    "check_replaceable",
    "claim_output",
    "is_marked_output",
    "lock_path",
    "read_marker",
    "recover_output",
    "write_marker",
    "atomic_savez",
    "atomic_write",
    "atomic_write_json",
    "atomic_write_text",
    "default_out_dir",
    "ensure_writable_dir",
    "new_sibling",
    "output_folder",
    "stdout_to_stderr",
    "swap_into_place",
    "to_jsonable",
]


def to_jsonable(obj: Any) -> Any:
    """Convert ``obj`` to plain JSON types (dict, list, str, int, float, bool, None).

    Parameters
    ----------
    obj : Any
        Nested structure of dicts, lists/tuples/sets, dataclass instances, numpy scalars and
        arrays, :class:`pathlib.Path`, enums, dates, complex numbers and Python scalars.

    Returns
    -------
    Any
        The same structure in JSON types: numpy scalars become Python scalars, arrays nested
        lists, dataclasses dicts of their fields, paths strings, enums their value, dates ISO
        strings, complex numbers ``{"real": x, "imag": y}``, mapping keys strings, and every
        NaN or infinite float ``None``.

    Raises
    ------
    TypeError
        For an object with no JSON representation (the message names its type).
    """
    if obj is None or isinstance(obj, (bool, str)):
        return obj
    if isinstance(obj, (int, np.integer)) and not isinstance(obj, np.bool_):
        return int(obj)
    if isinstance(obj, np.bool_):
        return bool(obj)
    if isinstance(obj, (float, np.floating)):
        value = float(obj)
        return value if math.isfinite(value) else None
    if isinstance(obj, (complex, np.complexfloating)):
        value = complex(obj)
        return {"real": to_jsonable(value.real), "imag": to_jsonable(value.imag)}
    if isinstance(obj, np.ndarray):
        return [to_jsonable(item) for item in obj.tolist()] if obj.ndim else to_jsonable(obj[()])
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        return {f.name: to_jsonable(getattr(obj, f.name)) for f in dataclasses.fields(obj)}
    if isinstance(obj, Mapping):
        return {
            str(to_jsonable(k)) if not isinstance(k, str) else k: to_jsonable(v)
            for k, v in obj.items()
        }
    if isinstance(obj, (list, tuple)):
        return [to_jsonable(item) for item in obj]
    if isinstance(obj, (set, frozenset)):
        return [to_jsonable(item) for item in sorted(obj, key=repr)]
    if isinstance(obj, os.PathLike):
        return os.fspath(obj)
    if isinstance(obj, enum.Enum):
        return to_jsonable(obj.value)
    if isinstance(obj, (_dt.datetime, _dt.date, _dt.time)):
        return obj.isoformat()
    raise TypeError(f"cannot convert an object of type {type(obj).__name__} to JSON")


def _fsync_dir(folder: Path) -> None:
    """Flush a directory entry to disk after a rename (POSIX only; best effort)."""
    if os.name != "posix":
        return
    try:
        fd = os.open(folder, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


def atomic_write(path: str | os.PathLike, write: Callable[[BinaryIO], None]) -> Path:
    """Write through ``write(file)`` into a temporary sibling of ``path``, then replace.

    Parameters
    ----------
    path : str or os.PathLike
        Target file; its folder must exist.
    write : callable
        ``write(handle)`` writes the content to a binary file handle.

    Returns
    -------
    pathlib.Path
        The target path.
    """
    target = Path(path)
    folder = target.parent
    # os.open with mode 0o666 lets the process umask set the permissions, as for open(); a
    # random suffix and O_EXCL keep concurrent writers of the same target apart.
    tmp_name = folder / f".{target.name}.{uuid.uuid4().hex[:12]}.tmp"
    fd = os.open(tmp_name, os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_BINARY", 0), 0o666)
    try:
        with os.fdopen(fd, "wb") as handle:
            write(handle)
            handle.flush()
            os.fsync(handle.fileno())
        os.replace(tmp_name, target)
    except BaseException:
        try:
            os.unlink(tmp_name)
        except OSError:
            pass
        raise
    _fsync_dir(folder)
    return target


def atomic_write_text(path: str | os.PathLike, text: str) -> Path:
    """Write ``text`` to ``path`` (UTF-8) atomically.

    Parameters
    ----------
    path : str or os.PathLike
        Target file; its folder must exist.
    text : str
        Content.

    Returns
    -------
    pathlib.Path
        The target path.
    """
    data = text.encode("utf-8")
    return atomic_write(path, lambda handle: handle.write(data))


def atomic_write_json(path: str | os.PathLike, obj: Any, *, indent: int | None = 2) -> Path:
    """Write ``obj`` as strict JSON to ``path`` atomically.

    ``obj`` is passed through :func:`to_jsonable` first, so numpy values, dataclasses and
    paths are accepted and NaN/inf are written as ``null``; the output never contains the
    non-standard tokens ``NaN`` or ``Infinity``.

    Parameters
    ----------
    path : str or os.PathLike
        Target file; its folder must exist.
    obj : Any
        Data to write.
    indent : int or None, optional
        JSON indentation [characters]; ``None`` for one line.

    Returns
    -------
    pathlib.Path
        The target path.
    """
    text = json.dumps(to_jsonable(obj), indent=indent, allow_nan=False, ensure_ascii=False)
    return atomic_write_text(path, text + "\n")


def atomic_savez(path: str | os.PathLike, **arrays: Any) -> Path:
    """Save arrays to an uncompressed ``.npz`` archive atomically.

    Unlike :func:`numpy.savez`, the file is written exactly at ``path``: no ``.npz`` suffix is
    appended.

    Parameters
    ----------
    path : str or os.PathLike
        Target file; its folder must exist.
    **arrays : array_like
        Arrays stored under their keyword names.

    Returns
    -------
    pathlib.Path
        The target path.
    """
    return atomic_write(path, lambda handle: np.savez(handle, **arrays))


def ensure_writable_dir(path: str | os.PathLike, field: str = "out") -> Path:
    """Create ``path`` (with parents) if needed and check that files can be written in it.

    Parameters
    ----------
    path : str or os.PathLike
        Output folder.
    field : str, optional
        Field name used in the error (the CLI option or config key that gave the folder).

    Returns
    -------
    pathlib.Path
        The folder as an absolute path.

    Raises
    ------
    BridgeflapInputError
        If the folder cannot be created or written to. Folders created by this call are
        removed again before raising, so a failed call creates nothing.
    """
    folder = Path(path).expanduser().absolute()
    if folder.exists() and not folder.is_dir():
        raise BridgeflapInputError(field, f"{folder} exists and is not a folder")
    missing = []
    probe = folder
    while not probe.exists() and probe != probe.parent:
        missing.append(probe)
        probe = probe.parent
    created: list[Path] = []
    try:
        for new in reversed(missing):
            new.mkdir()
            created.append(new)
        fd, probe_name = tempfile.mkstemp(prefix=".write-test.", suffix=".tmp", dir=folder)
        os.close(fd)
        os.unlink(probe_name)
    except OSError as exc:
        for new in reversed(created):
            try:
                new.rmdir()
            except OSError:
                pass
        reason = exc.strerror or type(exc).__name__
        raise BridgeflapInputError(field, f"cannot write to {folder}: {reason}") from exc
    return folder


def default_out_dir(name: str) -> Path:
    """``runs/<name>/output`` relative to the current directory."""
    return Path.cwd() / "runs" / name / "output"


def output_folder(out: str | os.PathLike | None, name: str) -> Path:
    """The absolute output folder ``out`` (default :func:`default_out_dir`), not a file."""
    target = Path(out).expanduser().absolute() if out is not None else default_out_dir(name)
    if target.exists() and not target.is_dir():
        raise BridgeflapInputError("out", f"{target} exists and is not a folder")
    return target


def new_sibling(target: Path, tag: str) -> Path:
    """A fresh hidden path next to ``target`` (``.<name>.<tag>-<random>``), not created."""
    return target.parent / f".{target.name}.{tag}-{uuid.uuid4().hex[:10]}"


# ---------------------------------------------------------------------------- output folders

#: marker file inside every output folder a bridgeflap run wrote (a JSON tag, see module doc)
OUTPUT_MARKER = ".bridgeflap-output"
#: test hook (fault tests only; unset in normal use): ``kill-mid-swap`` SIGKILLs the process
#: between the two renames of a swap, ``fail-before-swap`` raises just before the swap,
#: ``pause-before-swap`` waits there (see :func:`_fault`)
FAULT_ENV = "BRIDGEFLAP_TEST_FAULT"
_TOOL = "bridgeflap"
_HELD: dict[str, list] = {}  # lock path -> [FileLock, depth]: claims are re-entrant per process


def _version() -> str:
    try:
        import importlib.metadata

        return importlib.metadata.version("bridgeflap")
    except Exception:  # noqa: BLE001 - not installed: the tag still names the tool
        return "unknown"


def write_marker(folder: str | os.PathLike, kind: str) -> Path:
    """Mark ``folder`` as a bridgeflap output of ``kind`` (writes :data:`OUTPUT_MARKER`)."""
    tag = {"tool": _TOOL, "kind": kind, "version": _version(), "pid": os.getpid(),
           "host": socket.gethostname(),
           "created_utc": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds")}
    return atomic_write_json(Path(folder) / OUTPUT_MARKER, tag)


def read_marker(folder: str | os.PathLike) -> dict | None:
    """The marker tag of ``folder``, or ``None`` if it has no valid bridgeflap marker."""
    try:
        tag = json.loads((Path(folder) / OUTPUT_MARKER).read_text("utf-8"))
    except (OSError, ValueError):
        return None
    return tag if isinstance(tag, dict) and tag.get("tool") == _TOOL else None


def is_marked_output(folder: str | os.PathLike) -> bool:
    """Whether ``folder`` is a folder a bridgeflap run marked as its own."""
    return read_marker(folder) is not None


def check_replaceable(target: str | os.PathLike, field: str = "out") -> Path:
    """Refuse an existing non-empty folder that bridgeflap did not write; write nothing.

    Parameters
    ----------
    target : str or os.PathLike
        The output folder a run is about to replace or write into.
    field : str, optional
        Field named in the error (the CLI option).

    Returns
    -------
    pathlib.Path
        ``target`` as an absolute path.

    Raises
    ------
    BridgeflapInputError
        ``target`` is a file, cannot be listed, or is a non-empty folder without a valid
        :data:`OUTPUT_MARKER`.
    """
    folder = Path(target).expanduser().absolute()
    if not folder.exists() and not folder.is_symlink():
        return folder
    if not folder.is_dir():
        raise BridgeflapInputError(field, f"{folder} exists and is not a folder")
    try:
        with os.scandir(folder) as entries:
            empty = next(entries, None) is None
    except OSError as exc:
        raise BridgeflapInputError(field, f"cannot read {folder}: {exc.strerror}") from None
    if not empty and not is_marked_output(folder):
        raise BridgeflapInputError(
            field, f"{folder} is a non-empty folder not written by bridgeflap (no "
                   f"{OUTPUT_MARKER} marker); refusing to replace it (choose another --out, "
                   "or empty it)")
    return folder


def lock_path(target: str | os.PathLike) -> Path:
    """The lock file of output folder ``target``: ``.<name>.lock`` next to it."""
    folder = Path(target).expanduser().absolute()
    return folder.parent / f".{folder.name}.lock"


def _pid_alive(pid: Any) -> bool:
    """Whether process ``pid`` runs on this host (a zombie counts as gone)."""
    if isinstance(pid, bool) or not isinstance(pid, int) or pid <= 0:
        return False
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:  # e.g. EPERM: it exists, owned by someone else
        return True
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
        return stat.rsplit(")", 1)[1].split()[0] != "Z"
    except (OSError, IndexError):
        return True


def _dead_writer(folder: Path, name_pid: int | None = None) -> bool:
    """A marked temporary whose writing process (on this host) is gone."""
    tag = read_marker(folder)
    if tag is None:
        return False
    if name_pid is not None:
        return not _pid_alive(name_pid)
    return tag.get("host") == socket.gethostname() and not _pid_alive(tag.get("pid"))


def _siblings(target: Path, tag: str) -> list[Path]:
    prefix = f".{target.name}.{tag}-"
    try:
        return sorted(p for p in target.parent.iterdir()
                      if p.name.startswith(prefix) and p.is_dir() and not p.is_symlink())
    except OSError:
        return []


def _backup_pid(path: Path, target: Path) -> int | None:
    rest = path.name[len(f".{target.name}.old-"):]
    head = rest.split("-", 1)[0]
    return int(head) if head.isdigit() else None


def recover_output(target: str | os.PathLike, say: Callable[[str], None] | None = None) -> list:
    """Undo what crashed runs left around ``target`` (call with the lock held).

    * target missing, a marked backup ``.<name>.old-<pid>-*`` of a dead swapper present: the
      newest backup is renamed back to ``target`` (the previous output is recovered);
    * other marked backups of dead swappers (the target exists): deleted;
    * marked temporaries ``.<name>.tmp-*`` whose writer is gone: deleted.

    Unmarked folders are never touched. Returns the actions as one-line texts (also given to
    ``say``).
    """
    target = Path(target).expanduser().absolute()
    actions = []
    backups = [b for b in _siblings(target, "old") if _dead_writer(b, _backup_pid(b, target))]
    if backups and not target.exists():
        newest = max(backups, key=lambda b: b.stat().st_mtime)
        os.rename(newest, target)
        _fsync_dir(target.parent)
        backups.remove(newest)
        actions.append(f"recovered the previous output {target} from an interrupted replace "
                       f"({newest.name})")
    for stale in backups:
        shutil.rmtree(stale, ignore_errors=True)
        actions.append(f"removed the stale backup {stale.name}")
    for stale in _siblings(target, "tmp"):
        if _dead_writer(stale):
            shutil.rmtree(stale, ignore_errors=True)
            actions.append(f"removed the temporary folder {stale.name} of a run that died")
    for text in actions:
        (say or _stderr)(f"bridgeflap: {text}")
    return actions


def _stderr(text: str) -> None:
    print(text, file=sys.stderr, flush=True)


@contextlib.contextmanager
def claim_output(target: str | os.PathLike, field: str = "out",
                 say: Callable[[str], None] | None = None):
    """Hold the run lock of output folder ``target`` meanwhile; refuse a foreign folder.

    In order: :func:`check_replaceable` (nothing written on refusal), create the parent
    folder, take the lock ``.<name>.lock`` next to ``target`` without waiting (a second run is
    refused with one line), :func:`recover_output`, and check ``target`` again under the lock.
    Re-entrant within one process (a DOE claims its folder, then its batch does).

    Yields
    ------
    pathlib.Path
        ``target`` as an absolute path.

    Raises
    ------
    BridgeflapInputError
        Foreign non-empty folder, unwritable parent, or another run holds the lock.
    """
    from filelock import FileLock, Timeout

    folder = check_replaceable(target, field)
    lock_file = lock_path(folder)
    key = str(lock_file)
    if key in _HELD:
        _HELD[key][1] += 1
        try:
            yield folder
        finally:
            _HELD[key][1] -= 1
        return
    ensure_writable_dir(folder.parent, field)
    lock = FileLock(lock_file, timeout=0)
    try:
        lock.acquire(timeout=0, blocking=False)
    except Timeout:
        raise BridgeflapInputError(
            field, f"another bridgeflap run is writing {folder} (lock {lock_file.name} held); "
                   "wait for it or choose another --out") from None
    except OSError as exc:
        raise BridgeflapInputError(field, f"cannot lock {lock_file}: {exc.strerror}") from None
    _HELD[key] = [lock, 1]
    try:
        recover_output(folder, say)
        check_replaceable(folder, field)
        yield folder
    finally:
        del _HELD[key]
        lock.release()


def _fault(point: str) -> None:
    """Fault injection for the crash tests (:data:`FAULT_ENV`; nothing when unset).

    ``kill-mid-swap``: SIGKILL between the renames; ``fail-before-swap``: raise before the
    swap; ``pause-before-swap``: create ``$BRIDGEFLAP_TEST_PAUSE_FILE.reached`` and wait (at
    most 300 s) while ``$BRIDGEFLAP_TEST_PAUSE_FILE`` exists, holding the lock meanwhile.
    """
    wanted = os.environ.get(FAULT_ENV)
    if not wanted:
        return
    if wanted == "pause-before-swap" and point == "fail-before-swap":
        pause = Path(os.environ.get("BRIDGEFLAP_TEST_PAUSE_FILE", ""))
        Path(f"{pause}.reached").touch()
        import time

        deadline = time.monotonic() + 300.0
        while pause.exists() and time.monotonic() < deadline:
            time.sleep(0.05)
        return
    if wanted != point:
        return
    if point == "kill-mid-swap":
        os.kill(os.getpid(), signal.SIGKILL)
    raise RuntimeError(f"injected fault {point} ({FAULT_ENV})")


def swap_into_place(tmp: Path, target: Path) -> None:
    """Replace ``target`` by the complete folder ``tmp`` (hold :func:`claim_output`).

    The previous folder is renamed to ``.<name>.old-<pid>-<random>`` first and deleted only
    after the new one is in place; after a crash between the renames :func:`recover_output`
    restores it. An empty previous folder is simply removed.
    """
    _fault("fail-before-swap")
    old = None
    if target.exists():
        try:
            target.rmdir()  # an empty folder (e.g. made by the user for us): nothing to keep
        except OSError:
            old = target.parent / f".{target.name}.old-{os.getpid()}-{uuid.uuid4().hex[:8]}"
            os.rename(target, old)
            _fsync_dir(target.parent)
    _fault("kill-mid-swap")
    try:
        os.rename(tmp, target)
    except OSError:
        if old is not None:
            os.rename(old, target)
        raise
    _fsync_dir(target.parent)
    if old is not None:
        shutil.rmtree(old, ignore_errors=True)


@contextlib.contextmanager
def stdout_to_stderr():
    """Send file descriptor 1 to stderr meanwhile (solvers such as Ipopt print from C), so
    that ``--json`` keeps stdout to exactly one JSON object."""
    try:
        sys.stdout.flush()
        saved = os.dup(1)
    except (OSError, ValueError, AttributeError):
        yield
        return
    try:
        os.dup2(2, 1)
        yield
    finally:
        try:
            sys.stdout.flush()
        except (OSError, ValueError):
            pass
        os.dup2(saved, 1)
        os.close(saved)
