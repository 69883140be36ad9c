"""Output folders: ownership marker, run lock, crash-safe replace, recovery after a crash.

Output *folders* (``study``, ``doe``, batch folders) follow four rules, all here:

* **Ownership.** Every folder a run writes carries the marker file :data:`OUTPUT_MARKER`
  (``.bridgeflap-output``, a JSON tag ``{"tool": "bridgeflap", "kind", "version", "pid",
  "host", "created_utc"}``). A run replaces or reuses only a folder that is missing, empty or
  marked; an existing non-empty folder without the marker (a user's own files) is refused
  with :class:`~bridgeflap.model.errors.BridgeflapInputError` naming ``out``, before anything is
  written (:func:`check_replaceable`).
* **One run at a time.** :func:`claim_output` takes a non-blocking :mod:`filelock` lock on
  ``.<name>.lock`` *next to* the folder (never inside the folder being replaced); a second run
  into the same folder is refused at once. On POSIX the lock file is removed, still locked,
  when the run ends (:class:`_RunLock` checks after locking that the path still names the file
  it locked, so two runs never hold "the" lock); no ``.<name>.lock`` is left behind.
* **Crash-safe replace.** :func:`swap_into_place` renames the previous folder to a backup
  ``.<name>.old-<pid>-<random>``, renames the complete new folder to the target, then deletes
  the backup. A kill between the two renames leaves no target but a complete, marked backup:
  the next run into that folder (under the lock, so no live run is mid-swap) renames the
  backup back first (:func:`recover_output`), then proceeds. A kill after the second rename
  leaves a stale backup next to the new folder, deleted at the next run. (A symlink swap would
  make the replace atomic for readers but turns every output folder into a link, which users
  copy and archive badly; the rename pair plus recovery keeps plain folders.)
* **Stale temporaries.** Temporary folders ``.<name>.tmp-<pid>-<random>``
  (:func:`temporary_sibling`) carry the writer's pid in their name and the marker; the next
  run deletes those named exactly so, marked, whose process is gone (one killed before its
  marker was written only if it is empty); a folder of the user's is never deleted, whatever
  its name. The
  half-written ``.<file>.<random>.tmp`` files of :func:`bridgeflap.design.io.files.atomic_write`
  that a killed batch leaves in its folder are deleted by the next run under the lock
  (:func:`remove_stale_file_temporaries`).
* **Validation first.** Callers check all their input before :func:`claim_output`, so a
  refused run writes nothing, not even the lock file.
"""

from __future__ import annotations

import contextlib
import datetime as _dt
import json
import os
import re
import shutil
import signal
import socket
import sys
import threading
import uuid
from collections.abc import Callable
from pathlib import Path
from typing import Any

from bridgeflap.design.io.files import _fsync_dir, atomic_write_json, ensure_writable_dir
from bridgeflap.model.errors import BridgeflapInputError

__all__ = [
    "FAULT_ENV",
    "OUTPUT_MARKER",
    "check_replaceable",
    "claim_output",
    "is_marked_output",
    "lock_path",
    "pid_alive",
    "read_marker",
    "recover_output",
    "remove_stale_file_temporaries",
    "swap_into_place",
    "temporary_sibling",
    "write_marker",
]

#: marker file inside every output folder a bridgeflap run wrote (a JSON tag, see module doc)
OUTPUT_MARKER = ".bridgeflap-output"
#: test hook (fault tests only; unset in normal use): ``kill-mid-swap`` SIGKILLs the process
#: between the two renames of a swap, ``fail-before-swap`` raises just before the swap,
#: ``pause-before-swap`` waits there (see :func:`_fault`)
FAULT_ENV = "BRIDGEFLAP_TEST_FAULT"
_TOOL = "bridgeflap"
_HELD: dict[tuple, list] = {}  # (lock path, thread) -> [FileLock, depth]: re-entrant claims


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


def check_replaceable(target: str | os.PathLike, field: str = "out",
                      kind: str | None = None) -> Path:
    """Refuse an existing non-empty folder that bridgeflap did not write; write nothing.

    Output folders are typed: with ``kind`` given, a folder whose marker names another kind
    (a DOE folder for a study, a study for ``optimise``) is refused too, untouched, with both
    kinds named, so one command's output is never replaced by another's.

    Parameters
    ----------
    target : str or os.PathLike
        The output folder a run is about to replace or write into.
    field : str, optional
        Field named in the error (the CLI option).
    kind : str, optional
        The kind of output about to be written (``"study"``, ``"optimise"``, ``"doe"``, ...);
        ``None`` skips the kind check.

    Returns
    -------
    pathlib.Path
        ``target`` as an absolute path.

    Raises
    ------
    BridgeflapInputError
        ``target`` is a file, cannot be listed, is a non-empty folder without a valid
        :data:`OUTPUT_MARKER`, or holds another kind of bridgeflap output.
    """
    folder = Path(target).expanduser().absolute()
    if not folder.exists() and not folder.is_symlink():
        return folder
    if not folder.is_dir():
        raise BridgeflapInputError(field, f"{folder} exists and is not a folder")
    if os.name == "posix" and (not os.access(folder, os.W_OK | os.X_OK)
                               or not folder.stat().st_mode & 0o200):  # root: the mode bits
        raise BridgeflapInputError(field, f"{folder} is a read-only folder; refusing to replace "
                                          "it (make it writable, or choose another --out)")
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
    if kind is not None and not empty:
        tag = read_marker(folder)
        other = tag.get("kind") if tag is not None else None
        if other != kind:
            raise BridgeflapInputError(
                field, f"{folder} holds a bridgeflap {other} output, not a {kind} output; "
                       f"refusing to replace it (choose another --{field.replace('_', '-')})")
    return folder


def lock_path(target: str | os.PathLike) -> Path:
    """The lock file of output folder ``target``: ``.<name>.lock`` next to it."""
    folder = Path(target).expanduser().absolute()
    return folder.parent / f".{folder.name}.lock"


def _pid_alive(pid: Any) -> bool:
    """Whether process ``pid`` runs on this host (a zombie counts as gone)."""
    if isinstance(pid, bool) or not isinstance(pid, int) or pid <= 0:
        return False
    if pid == os.getpid() or os.name != "posix":
        # (on Windows os.kill(pid, 0) would terminate the process: never probe, never clean)
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


def pid_alive(pid: Any) -> bool:
    """Whether process ``pid`` runs on this host (a zombie counts as gone; on Windows, and for
    this process, always true: never probed)."""
    return _pid_alive(pid)


def _dead_writer(folder: Path, name_pid: int | None) -> bool:
    """A temporary or backup of ours whose writing process (on this host) is gone.

    Ours: named exactly as bridgeflap names it (``name_pid``, the pid in the name, not
    ``None``) and carrying the marker; a folder without the marker, or named otherwise, is
    never ours, whatever its name looks like.
    """
    tag = read_marker(folder)
    if tag is None or name_pid is None:
        return False
    return not _pid_alive(name_pid)


def temporary_sibling(target: Path) -> Path:
    """A fresh temporary folder path next to ``target``: ``.<name>.tmp-<pid>-<random>``."""
    return target.parent / f".{target.name}.tmp-{os.getpid()}-{uuid.uuid4().hex[:8]}"


_OUR_SUFFIX = re.compile(r"^([1-9][0-9]{0,9})-[0-9a-f]{8}$")  # <pid>-<8 hex>: ours exactly


def _name_pid(path: Path, target: Path, tag: str) -> int | None:
    """The pid in ``.<name>.<tag>-<pid>-<random>`` spelt exactly as bridgeflap spells it
    (``<random>`` 8 hex digits), ``None`` for any other spelling (a user's own folder)."""
    match = _OUR_SUFFIX.match(path.name[len(f".{target.name}.{tag}-"):])
    return int(match.group(1)) if match else None


def _siblings(target: Path, tag: str) -> list[Path]:
    prefix = f".{target.name}.{tag}-"
    try:
        return sorted(p for p in target.parent.iterdir()
                      if p.name.startswith(prefix) and p.is_dir() and not p.is_symlink())
    except OSError:
        return []


def recover_output(target: str | os.PathLike, say: Callable[[str], None] | None = None) -> list:
    """Undo what crashed runs left around ``target`` (call with the lock held).

    * target missing, a marked backup ``.<name>.old-<pid>-*`` of a dead swapper present: the
      newest backup is renamed back to ``target`` (the previous output is recovered);
    * other marked backups of dead swappers (the target exists): deleted;
    * marked temporaries ``.<name>.tmp-*`` whose writer is gone: deleted; an unmarked one
      named exactly as ours (``.<name>.tmp-<pid>-<8 hex>``, killed between its ``mkdir`` and
      its marker) only if it is empty or holds nothing but its half-written marker
      (:func:`os.rmdir`: nothing in it can be lost).

    Unmarked folders are never deleted with their content. Returns the actions as one-line
    texts (also given to ``say``).
    """
    target = Path(target).expanduser().absolute()
    actions = []
    backups = [b for b in _siblings(target, "old") if _dead_writer(b, _name_pid(b, target, "old"))]
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
        pid = _name_pid(stale, target, "tmp")
        if _dead_writer(stale, pid):
            shutil.rmtree(stale, ignore_errors=True)
            actions.append(f"removed the temporary folder {stale.name} of a run that died")
        elif pid is not None and not _pid_alive(pid) and read_marker(stale) is None:
            with contextlib.suppress(OSError):  # not empty: not provably ours, kept
                _remove_marker_temporaries(stale)   # killed while writing its marker
                os.rmdir(stale)
                actions.append(f"removed the empty temporary folder {stale.name} of a run "
                               "that died")
    for text in actions:
        (say or _stderr)(f"bridgeflap: {text}")
    return actions


_ATOMIC_TMP = re.compile(r"^\..+\.[0-9a-f]{12}\.tmp$")


def _remove_marker_temporaries(folder: Path) -> None:
    """In an unmarked temporary folder of a dead writer: delete the half-written marker
    (:func:`write_marker` writes it through :func:`atomic_write`, a temporary file
    ``..bridgeflap-output.<12 hex>.tmp`` first) when that is all the folder holds, so that
    the folder is then empty. A folder with anything else in it is left as it is."""
    entries = list(folder.iterdir())
    if entries and all(e.is_file() and not e.is_symlink() and _ATOMIC_TMP.match(e.name)
                       and e.name.startswith(f".{OUTPUT_MARKER}.") for e in entries):
        for e in entries:
            e.unlink()


def remove_stale_file_temporaries(folder: str | os.PathLike) -> int:
    """Delete the ``.<name>.<random>.tmp`` files :func:`atomic_write` leaves when its process
    is killed mid-write, directly in ``folder``; call only with the folder's lock held (no live
    writer then). Returns how many were removed."""
    removed = 0
    try:
        entries = list(Path(folder).iterdir())
    except OSError:
        return 0
    for path in entries:
        if _ATOMIC_TMP.match(path.name) and path.is_file() and not path.is_symlink():
            try:
                path.unlink()
                removed += 1
            except OSError:
                pass
    return removed


def _stderr(text: str) -> None:
    print(text, file=sys.stderr, flush=True)


@contextlib.contextmanager
def claim_output(target: str | os.PathLike, field: str = "out",
                 say: Callable[[str], None] | None = None, kind: str | None = None):
    """Hold the run lock of output folder ``target`` meanwhile; refuse a foreign folder.

    In order: :func:`check_replaceable` (nothing written on refusal), create the parent
    folder, take the lock ``.<name>.lock`` next to ``target`` without waiting (a second run is
    refused with one line), :func:`recover_output`, and check ``target`` again under the lock.
    Re-entrant within one thread (a DOE claims its folder, then its batch does); another
    thread or process is refused.

    Yields
    ------
    pathlib.Path
        ``target`` as an absolute path.

    Raises
    ------
    BridgeflapInputError
        Foreign non-empty folder, unwritable parent, or another run holds the lock.
    """
    folder = check_replaceable(target, field, kind)
    lock_file = lock_path(folder)
    key = (str(lock_file), threading.get_ident())  # re-entrant per thread, not per process
    if key in _HELD:
        _HELD[key][1] += 1
        try:
            yield folder
        finally:
            _HELD[key][1] -= 1
        return
    ensure_writable_dir(folder.parent, field)
    lock = _RunLock(lock_file)
    if lock_file.is_symlink():
        raise BridgeflapInputError(field, f"the lock {lock_file} is a symbolic link; refusing to "
                                          "follow it (remove it)")
    try:
        held = lock.acquire()
    except OSError as exc:
        raise BridgeflapInputError(field, f"cannot lock {lock_file}: {exc.strerror}") from None
    if not held:
        raise BridgeflapInputError(
            field, f"another bridgeflap run is writing {folder} (lock {lock_file.name} held); "
                   "wait for it or choose another --out")
    _HELD[key] = [lock, 1]
    try:
        recover_output(folder, say)
        check_replaceable(folder, field, kind)
        yield folder
    finally:
        del _HELD[key]
        lock.release()


class _RunLock:
    """An exclusive, non-waiting lock file that is removed when released.

    ``flock`` on a file opened afresh (so another thread of this process is refused too), then
    a check that the path still names the locked file: a run that opened the file just before
    its holder removed it holds a lock on a deleted file and is refused like a held lock. The
    file is removed while still locked, so no lock file is left behind a finished or refused
    run. Without ``fcntl`` (not POSIX), :mod:`filelock` is used and its
    file stays.
    """

    def __init__(self, path: Path):
        self.path = path
        self._fd: int | None = None
        self._fallback = None

    def acquire(self) -> bool:
        try:
            import fcntl
        except ImportError:  # pragma: no cover - not POSIX
            from filelock import FileLock, Timeout

            self._fallback = FileLock(self.path, timeout=0)
            try:
                self._fallback.acquire(timeout=0, blocking=False)
            except Timeout:
                return False
            return True
        # never through a symbolic link: a planted .<name>.lock link would otherwise make us
        # create a file at its target, outside the output folder's parent
        fd = os.open(self.path, os.O_RDWR | os.O_CREAT | getattr(os, "O_NOFOLLOW", 0), 0o644)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            os.close(fd)
            return False
        except OSError:
            os.close(fd)
            raise
        try:
            same = os.stat(self.path).st_ino == os.fstat(fd).st_ino
        except FileNotFoundError:
            same = False
        if not same:  # its holder removed it between our open and flock: it was held
            os.close(fd)
            return False
        self._fd = fd
        return True

    def release(self) -> None:
        if self._fallback is not None:  # pragma: no cover - not POSIX
            self._fallback.release()
            return
        if self._fd is None:
            return
        with contextlib.suppress(OSError):
            os.unlink(self.path)  # still locked: nobody can take the name in between
        os.close(self._fd)
        self._fd = None


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
    if old is not None and old.is_symlink():
        old.unlink()  # the target was a link to a folder: drop the link, keep what it named
    elif old is not None:
        shutil.rmtree(old, ignore_errors=True)


