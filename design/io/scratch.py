"""Scratch folders in the system temp folder that no killed run leaves behind.

A scratch folder is named ``bridgeflap-<kind>-<pid>-<random>``: the process that owns it, by
its id. :func:`scratch_folder` makes one and removes it when the block ends; a process killed
meanwhile (``kill -9`` runs no clean-up) leaves it, and the next :func:`scratch_folder` of the
same kind removes every such folder whose owner is no longer alive
(:func:`remove_stale_scratch`). Folders of live processes, and folders named otherwise, are
never touched.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import tempfile
from pathlib import Path

from bridgeflap.design.io.outputs import pid_alive

__all__ = ["remove_stale_scratch", "scratch_folder", "scratch_prefix"]


def scratch_prefix(kind: str) -> str:
    """The name prefix of ``kind``'s scratch folders, before the owner's pid."""
    return f"bridgeflap-{kind}-"


def remove_stale_scratch(kind: str, root: str | os.PathLike | None = None) -> list[Path]:
    """Remove ``kind``'s scratch folders in ``root`` (default: the system temp folder) whose
    owning process is gone; returns them."""
    prefix = scratch_prefix(kind)
    base = Path(tempfile.gettempdir() if root is None else root)
    removed = []
    try:
        entries = list(base.glob(f"{prefix}*"))
    except OSError:
        return removed
    for entry in entries:
        pid, sep, _ = entry.name[len(prefix):].partition("-")
        if not sep or not pid.isdigit() or entry.is_symlink() or not entry.is_dir():
            continue
        if pid_alive(int(pid)):
            continue
        shutil.rmtree(entry, ignore_errors=True)
        if not entry.exists():
            removed.append(entry)
    return removed


@contextlib.contextmanager
def scratch_folder(kind: str, root: str | os.PathLike | None = None):
    """A fresh scratch folder of ``kind`` (stale ones of dead owners removed first), removed
    when the block ends."""
    remove_stale_scratch(kind, root)
    path = Path(tempfile.mkdtemp(prefix=f"{scratch_prefix(kind)}{os.getpid()}-",
                                 dir=None if root is None else os.fspath(root)))
    try:
        yield path
    finally:
        shutil.rmtree(path, ignore_errors=True)
