"""Run manifest: what ran, where, with which software, on which source tree.

:func:`build_manifest` collects everything needed to reproduce or audit a run output folder
(written by the caller as ``manifest.json`` with
:func:`bridgeflap.design.io.files.atomic_write_json`). Nothing here imports the numerical packages:
versions come from the installed distributions' metadata, the Ipopt version from the files CasADi
ships, so building a manifest is cheap and has no side effects.
"""

from __future__ import annotations

import datetime as _dt
import importlib.metadata
import importlib.util
import json
import os
import platform
import re
import socket
import subprocess
import sys
from pathlib import Path
from typing import Any

from bridgeflap.design.io.files import to_jsonable

__all__ = ["build_info", "build_manifest", "git_info", "ipopt_version", "package_versions",
           "provenance"]

UNKNOWN = "unknown"
#: The version recorded for a package that is not installed (the optional python-control).
NOT_INSTALLED = "not installed"
#: Every scientific dependency whose version can change a number, a table or a figure (the
#: optional python-control included: "not installed" when it is not installed).
_PACKAGES = ("bridgeflap", "numpy", "scipy", "casadi", "matplotlib", "pandas", "xarray",
             "SALib", "control", "dask", "distributed", "tqdm", "threadpoolctl", "tabulate")
_GIT_TIMEOUT_S = 5.0
_ROOT = Path(__file__).resolve().parents[2]
#: The build record setup.py writes into the model package.
BUILD_INFO_NAME = "_build_info.json"


def package_versions() -> dict[str, str]:
    """Versions of bridgeflap and its numerical dependencies, plus CasADi's Ipopt.

    Returns
    -------
    dict of str to str
        Distribution name -> version; ``"ipopt"`` is the Ipopt bundled with CasADi. A package
        that is not installed is ``"not installed"``; one whose version cannot be read is
        ``"unknown"``.
    """
    versions = {name: package_versions_one(name) for name in _PACKAGES}
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
    root = Path(source_dir) if source_dir is not None else Path(__file__).resolve().parents[2]
    unknown = {"commit": UNKNOWN, "dirty": None}
    top = _git(["rev-parse", "--show-toplevel"], root)
    if top is None or Path(top).resolve() != root.resolve():
        return unknown
    commit = _git(["rev-parse", "HEAD"], root)
    if not commit:
        return unknown
    status = _git(["status", "--porcelain", "--untracked-files=no"], root)
    return {"commit": commit, "dirty": None if status is None else bool(status)}


def build_info(path: str | Path | None = None) -> dict[str, Any] | None:
    """The build record ``model/_build_info.json`` written by ``setup.py`` (``None`` if absent).

    Returns
    -------
    dict or None
        ``{"version", "commit", "dirty", "built_utc"}`` of the build this installation came
        from (a wheel or an sdist); ``None`` for a source checkout that was never built.
    """
    path = Path(path) if path is not None else _ROOT / "model" / BUILD_INFO_NAME
    try:
        data = json.loads(path.read_text())
    except (OSError, ValueError):
        return None
    return data if isinstance(data, dict) else None


def _source_version() -> str:
    """``project.version`` of the checkout's pyproject.toml (an uninstalled checkout)."""
    try:
        import tomllib
    except ImportError:  # Python 3.10
        import tomli as tomllib
    try:
        return str(tomllib.loads((_ROOT / "pyproject.toml").read_text())["project"]["version"])
    except (OSError, ValueError, KeyError, TypeError):
        return UNKNOWN


def provenance(source_dir: str | Path | None = None, build_path: str | Path | None = None
               ) -> dict[str, Any]:
    """Version and commit of the running bridgeflap, installed or not.

    The commit is the checkout's (:func:`git_info`) when the code runs from a git work tree,
    else the one recorded at build time (:func:`build_info`); ``source`` says which
    (``"checkout"``, ``"build"`` or ``"unknown"`` when neither exists). The version is the
    installed distribution's, else the build record's, else the checkout's pyproject.toml.
    """
    git = git_info(source_dir)
    build = build_info(build_path)
    version = package_versions_one("bridgeflap")
    if version in (UNKNOWN, NOT_INSTALLED):
        version = (build or {}).get("version") or _source_version()
    if git["commit"] != UNKNOWN:
        out = {**git, "source": "checkout"}
    elif build and build.get("commit", UNKNOWN) != UNKNOWN:
        out = {"commit": build["commit"], "dirty": build.get("dirty"), "source": "build"}
    else:
        out = {**git, "source": UNKNOWN}
    return {"version": version, **out, "built_utc": (build or {}).get("built_utc")}


def package_versions_one(name: str) -> str:
    """Installed version of distribution ``name``.

    Parameters
    ----------
    name : str
        Distribution name, e.g. ``"control"``.

    Returns
    -------
    str
        Its version; ``"not installed"`` when no such distribution is installed, ``"unknown"``
        when it is installed but records no version.
    """
    try:
        version = importlib.metadata.version(name)
    except importlib.metadata.PackageNotFoundError:
        return NOT_INSTALLED
    return version or UNKNOWN


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
        through :func:`bridgeflap.design.io.files.to_jsonable`.

    Returns
    -------
    dict
        JSON-ready mapping with keys ``time_utc`` (ISO 8601), ``host``, ``platform``,
        ``python``, ``packages`` (see :func:`package_versions`), ``git`` (``commit``,
        ``dirty`` and its ``source``, :func:`provenance`), ``bridgeflap`` (``version``,
        ``commit``, ``built_utc``), ``command_line`` (``sys.argv``), ``cwd`` and ``config``.
    """
    prov = provenance()
    return {
        "time_utc": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
        "host": socket.gethostname(),
        "platform": platform.platform(),
        "python": f"{platform.python_implementation()} {platform.python_version()}",
        "packages": package_versions(),
        "git": {k: prov[k] for k in ("commit", "dirty", "source")},
        "bridgeflap": {k: prov[k] for k in ("version", "commit", "built_utc")},
        "command_line": list(sys.argv),
        "cwd": _cwd(),
        "config": to_jsonable(config),
    }
