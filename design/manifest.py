"""Run manifest: what ran, where, with which software, on which source tree.

:func:`build_manifest` collects everything needed to reproduce or audit a run output folder
(written by the caller as ``manifest.json`` with :func:`design.io.atomic_write_json`). Nothing
here imports the numerical packages: versions come from the installed distributions'
metadata, the Ipopt version from the files CasADi ships, so building a manifest is cheap and
has no side effects.
"""

from __future__ import annotations

import datetime as _dt
import importlib.metadata
import importlib.util
import os
import platform
import re
import socket
import subprocess
import sys
from pathlib import Path
from typing import Any

from design.io import to_jsonable

__all__ = ["build_manifest", "git_info", "ipopt_version", "package_versions"]

UNKNOWN = "unknown"
_PACKAGES = ("bridgeflap", "numpy", "scipy", "casadi", "matplotlib", "dask", "distributed")
_GIT_TIMEOUT_S = 5.0


def package_versions() -> dict[str, str]:
    """Versions of bridgeflap and its numerical dependencies, plus CasADi's Ipopt.

    Returns
    -------
    dict of str to str
        Distribution name -> version; ``"ipopt"`` is the Ipopt bundled with CasADi. A package
        that is not installed or whose version cannot be read is ``"unknown"``.
    """
    versions = {}
    for name in _PACKAGES:
        try:
            versions[name] = importlib.metadata.version(name)
        except importlib.metadata.PackageNotFoundError:
            versions[name] = UNKNOWN
    versions["ipopt"] = ipopt_version()
    return versions


def ipopt_version() -> str:
    """Version of the Ipopt library bundled with the installed CasADi, or ``"unknown"``.

    Read, in order, from ``pkgconfig/ipopt.pc``, ``include/coin-or/IpoptConfig.h`` and the
    name of ``libipopt.so.X.Y.Z`` inside the ``casadi`` package folder, without importing
    casadi or loading the solver.
    """
    try:
        spec = importlib.util.find_spec("casadi")
    except (ImportError, ValueError):
        return UNKNOWN
    if spec is None or not spec.submodule_search_locations:
        return UNKNOWN
    root = Path(next(iter(spec.submodule_search_locations)))
    probes = (
        (root / "pkgconfig" / "ipopt.pc", r"^Version:\s*(\S+)"),
        (root / "include" / "coin-or" / "IpoptConfig.h", r'^#define\s+IPOPT_VERSION\s+"([^"]+)"'),
    )
    for path, pattern in probes:
        try:
            match = re.search(pattern, path.read_text(errors="replace"), flags=re.MULTILINE)
        except OSError:
            continue
        if match:
            return match.group(1)
    try:
        for lib in sorted(root.glob("libipopt*")):
            match = re.search(r"ipopt[.-]?(?:so\.|)(\d+\.\d+\.\d+)", lib.name)
            if match:
                return match.group(1)
    except OSError:
        pass
    return UNKNOWN


def _git(args: list[str], cwd: Path) -> str | None:
    """Run a read-only git command; ``None`` on any failure."""
    try:
        done = subprocess.run(
            ["git", *args],
            cwd=cwd,
            capture_output=True,
            text=True,
            timeout=_GIT_TIMEOUT_S,
            check=False,
        )
    except (OSError, subprocess.SubprocessError):
        return None
    return done.stdout.strip() if done.returncode == 0 else None


def git_info(source_dir: str | Path | None = None) -> dict[str, Any]:
    """Commit and dirty flag of the bridgeflap source checkout.

    Parameters
    ----------
    source_dir : str or pathlib.Path, optional
        Project root to inspect; default: the folder above this package. The commit is
        reported only when that folder *is* the top of a git work tree, so a wheel installed
        into a ``site-packages`` that happens to lie inside some other repository does not
        report that repository's commit.

    Returns
    -------
    dict
        ``{"commit": sha or "unknown", "dirty": bool or None}``; ``dirty`` is ``True`` when
        tracked files differ from the commit, ``None`` when unknown.
    """
    root = Path(source_dir) if source_dir is not None else Path(__file__).resolve().parent.parent
    unknown = {"commit": UNKNOWN, "dirty": None}
    top = _git(["rev-parse", "--show-toplevel"], root)
    if top is None or Path(top).resolve() != root.resolve():
        return unknown
    commit = _git(["rev-parse", "HEAD"], root)
    if not commit:
        return unknown
    status = _git(["status", "--porcelain", "--untracked-files=no"], root)
    return {"commit": commit, "dirty": None if status is None else bool(status)}


def _cwd() -> str:
    try:
        return os.getcwd()
    except OSError:  # the working folder was deleted
        return UNKNOWN


def build_manifest(config: dict) -> dict:
    """Describe the current run: time, machine, software versions, source commit, config.

    Parameters
    ----------
    config : dict
        The resolved run configuration (after defaults and command-line overrides); stored
        through :func:`design.io.to_jsonable`.

    Returns
    -------
    dict
        JSON-ready mapping with keys ``time_utc`` (ISO 8601), ``host``, ``platform``,
        ``python``, ``packages`` (see :func:`package_versions`), ``git`` (see
        :func:`git_info`), ``command_line`` (``sys.argv``), ``cwd`` and ``config``.
    """
    return {
        "time_utc": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
        "host": socket.gethostname(),
        "platform": platform.platform(),
        "python": f"{platform.python_implementation()} {platform.python_version()}",
        "packages": package_versions(),
        "git": git_info(),
        "command_line": list(sys.argv),
        "cwd": _cwd(),
        "config": to_jsonable(config),
    }
