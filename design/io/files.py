"""Output folders and atomic, self-describing output files.

Every file a run writes goes through this module so that an interrupted run never leaves a
half-written file behind: the data are written to a temporary file in the *same* folder
(``.<name>.<random>.tmp``), flushed and ``fsync``-ed, and then moved over the target with
:func:`os.replace`, which is atomic on POSIX and Windows when source and target are on the same
file system. A reader therefore sees either the old file or the complete new one.

Output folders (ownership marker, run lock, crash-safe replace):
:mod:`bridgeflap.design.io.outputs`.

JSON output is strict (RFC 8259): NaN and +-inf have no JSON spelling, so :func:`to_jsonable`
turns them into ``null``. A ``null`` number in a result file therefore means "not a finite
number" (failed solve, no flutter in the range, ...); the status field next to it says why.
"""

from __future__ import annotations

import contextlib
import json
import os
import sys
import tempfile
import uuid
from collections.abc import Callable
from pathlib import Path
from typing import Any, BinaryIO

import numpy as np

from bridgeflap.model.errors import BridgeflapInputError
from bridgeflap.model.results import jsonable

__all__ = [
    "atomic_save_netcdf",
    "atomic_savez",
    "atomic_write",
    "atomic_write_json",
    "atomic_write_text",
    "default_out_dir",
    "ensure_writable_dir",
    "naming_os_errors",
    "new_sibling",
    "output_folder",
    "stdout_to_stderr",
    "to_jsonable",
]


def to_jsonable(obj: Any) -> Any:
    """Convert ``obj`` to plain JSON types (dict, list, str, int, float, bool, None).

    The one converter of the package, :func:`bridgeflap.model.results.jsonable`: numpy scalars
    become Python scalars, arrays nested lists, dataclasses dicts of their fields, paths strings,
    enums their value, dates ISO strings, complex numbers ``{"real": x, "imag": y}``, mapping
    keys strings, and every NaN or infinite float ``None``.

    Raises
    ------
    TypeError
        For an object with no JSON representation (the message names its type).
    """
    return jsonable(obj)


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
    with naming_os_errors(target):
        fd = os.open(tmp_name, os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_BINARY", 0),
                     0o666)
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


@contextlib.contextmanager
def naming_os_errors(path: str | os.PathLike):
    """Meanwhile, an :class:`OSError` from the OS ("No space left on device", "Permission
    denied", "File name too long", ...) is raised again naming ``path`` (a write's ``ENOSPC``
    names no file, a temporary's error its temporary name), so that the CLI reports it as one
    line naming the file and the reason (:func:`bridgeflap.design.cli.common.os_error_as_input`)."""
    try:
        yield
    except OSError as exc:
        if exc.errno is None:
            raise
        raise OSError(exc.errno, exc.strerror or os.strerror(exc.errno),
                      os.fspath(path)) from exc


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


def atomic_save_netcdf(path: str | os.PathLike, dataset: Any) -> Path:
    """Write an :class:`xarray.Dataset` as NetCDF-3 (xarray's scipy engine) atomically.

    NetCDF-3 has no boolean attribute type: booleans are stored as ints; NaN is kept (NetCDF
    has a NaN). Read back with ``xarray.open_dataset(path, engine="scipy")``.
    """
    ds = dataset.copy()
    ds.attrs = {k: (int(v) if isinstance(v, bool) else v) for k, v in ds.attrs.items()}
    data = bytes(ds.to_netcdf(engine="scipy"))
    return atomic_write(path, lambda fh: fh.write(data))


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
