"""Read a finished run folder back: :func:`open_run` for study, DOE, screening and optimise folders.

Every folder a bridgeflap run writes carries the marker ``.bridgeflap-output`` naming its kind
(:mod:`bridgeflap.design.io.outputs`). :func:`open_run` reads the marker and the folder's files,
never re-runs anything, and returns a :class:`RunRecord`, a result like every other one
(:class:`bridgeflap.model.results.ResultData`): ``summary()``, ``to_dict()``, ``to_dataframe()``,
``to_xarray()``, ``table()``, ``plot()`` and the summary's headline numbers as attributes.

What each kind holds (see the documentation's "Output folders" page):

* ``study``: ``summary.json`` (the ``bridgeflap study --json`` payload), ``statuses.json``,
  ``results/<analysis>.json|.npz|.nc``, ``figures/``, ``report.md``/``report.html``;
* ``doe`` and batch folders (``sensitivity --global``): ``batch.json``, ``table.csv`` and
  ``cases/<case_id>.json``; an interrupted run has its finished cases only;
* ``optimise``: ``summary.json`` where the command wrote one, ``controller.toml``,
  ``ipopt_history.json``, the acceptance tables ``<check>.csv`` and the figures.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from bridgeflap.model.errors import BridgeflapInputError
from bridgeflap.model.results import ResultData

__all__ = ["RunRecord", "open_run"]


def _read_json(path: Path, field: str, kind: type | None = dict) -> Any:
    """The JSON value of ``path`` (a ``kind`` when given), or one line naming ``field`` and the
    file: truncated, not UTF-8, not JSON, the wrong kind of value, unreadable."""
    try:
        value = json.loads(path.read_text("utf-8"))
    except UnicodeDecodeError:
        raise BridgeflapInputError(field, f"{path} is not a text file (not UTF-8): "
                                          "corrupt or not written by bridgeflap") from None
    except json.JSONDecodeError as exc:
        raise BridgeflapInputError(field, f"{path} is not valid JSON (line {exc.lineno}, "
                                          f"column {exc.colno}: {exc.msg}): corrupt or "
                                          "truncated") from None
    except OSError as exc:
        raise BridgeflapInputError(field, f"cannot read {path}: "
                                          f"{exc.strerror or exc}") from None
    if kind is not None and not isinstance(value, kind):
        expected = "an object ({...})" if kind is dict else kind.__name__
        raise BridgeflapInputError(field, f"{path} holds {type(value).__name__}, expected "
                                          f"{expected}: not written by bridgeflap")
    return value


@dataclass(frozen=True, repr=False)
class RunRecord(ResultData):
    """A finished (or interrupted) run folder, read back.

    Attributes
    ----------
    folder : Path
        The folder.
    kind : str
        ``"study"``, ``"doe"``, ``"batch"``, ``"optimise"``, ... (the folder marker's kind).
    marker : dict
        The marker: bridgeflap version, host, creation time.
    data : dict
        The folder's summary: ``summary.json`` (study, optimise) or ``batch.json`` (DOE).
    """

    folder: Path
    kind: str
    marker: dict
    data: dict = field(default_factory=dict)

    _HEADLINE_KEYS = ("kind", "folder", "status", "cases", "succeeded", "failed", "reused",
                      "critical_speed_m_s")

    def summary(self) -> dict:
        """The folder's own summary, with ``kind`` and ``folder`` added.

        Returns
        -------
        dict
            ``kind`` (``study``, ``doe``, ``batch``, ``optimise``, ...), ``folder`` and the
            folder's ``summary.json``.
        """
        return {"kind": self.kind, "folder": str(self.folder), **self.data}

    # ----------------------------------------------------------------------- folder parts
    def path(self, name: str) -> Path:
        """A file of the folder (``run.path("report.html")``); it may not exist.

        Parameters
        ----------
        name : str
            A path relative to the folder.

        Returns
        -------
        pathlib.Path
            That path inside the folder.
        """
        return self.folder / name

    def files(self) -> list[str]:
        """Every file of the folder, relative to it, sorted (the marker included).

        Returns
        -------
        list of str
            The paths relative to the folder.
        """
        return sorted(str(p.relative_to(self.folder)) for p in self.folder.rglob("*")
                      if p.is_file())

    def results(self) -> dict[str, dict]:
        """A study's analysis results: analysis -> its ``results/<analysis>.json``.

        Returns
        -------
        dict
            Analysis name -> its result's JSON (``{}`` for a folder without ``results/``).

        Raises
        ------
        BridgeflapInputError
            Naming the file: it is not UTF-8 text, not valid JSON or not the expected kind
            (a corrupt folder).
        """
        out = {}
        for path in sorted((self.folder / "results").glob("*.json")):
            out[path.stem] = _read_json(path, f"results/{path.name}", None)
        return out

    def statuses(self) -> dict:
        """A study's ``statuses.json`` (analysis -> status), else the DOE case statuses.

        Returns
        -------
        dict
            Analysis name (a study) or case id (a DOE or batch) -> status.

        Raises
        ------
        BridgeflapInputError
            Naming the file: it is not UTF-8 text, not valid JSON or not the expected kind
            (a corrupt folder).
        """
        path = self.folder / "statuses.json"
        if path.is_file():
            return _read_json(path, "statuses.json")
        return {row["case_id"]: row["status"] for row in self.case_records()}

    def case_records(self) -> list[dict]:
        """A DOE's or batch's case records (``cases/<case_id>.json``), in case order.

        Returns
        -------
        list of dict
            One per case (``case_id``, ``params``, ``status``, ``error``, ``elapsed_s``,
            ``result``); empty for a folder without cases.

        Raises
        ------
        BridgeflapInputError
            Naming the file: it is not UTF-8 text, not valid JSON or not the expected kind
            (a corrupt folder).
        """
        paths = sorted((self.folder / "cases").glob("*.json"))
        return [_read_json(p, f"cases/{p.name}") for p in paths]

    def controller(self):
        """The designed controller (``controller.toml`` of an optimise folder, or
        ``results/controller.toml`` of a study), or ``None`` when there is none.

        Returns
        -------
        Controller or None
            The controller read from its file.

        Raises
        ------
        BridgeflapInputError
            ``controller...``: the controller file is unreadable or invalid.
        """
        from bridgeflap.model.aeroelastic.controller_file import load_controller

        for name in ("controller.toml", "results/controller.toml"):
            if (self.folder / name).is_file():
                return load_controller(self.folder / name)
        return None

    def dataset(self, analysis: str):
        """A study analysis's labelled arrays (``results/<analysis>.nc``) as an
        :class:`xarray.Dataset`.

        Parameters
        ----------
        analysis : str
            A study analysis (``"flutter"``, ``"erection"``, ...).

        Returns
        -------
        xarray.Dataset
            Its labelled arrays, loaded into memory.

        Raises
        ------
        BridgeflapInputError
            ``analysis``: the study wrote no arrays of it; ``results/<analysis>.nc``: the file
            cannot be read.
        """
        import xarray as xr

        path = self.folder / "results" / f"{analysis}.nc"
        if not path.is_file():
            raise BridgeflapInputError("analysis", f"no labelled arrays of {analysis!r} in "
                                                   f"{self.folder} (results/*.nc)")
        try:
            with xr.open_dataset(path, engine="scipy") as ds:
                return ds.load()
        except Exception as exc:  # noqa: BLE001 - any reader failure is a corrupt file here
            reason = " ".join(str(exc).split())[:200] or type(exc).__name__
            raise BridgeflapInputError(f"results/{path.name}", f"{path} cannot be read as "
                                       f"labelled arrays ({type(exc).__name__}: {reason}): "
                                       "corrupt or not written by bridgeflap") from None

    # ------------------------------------------------------------------- the common face
    def _rows(self) -> list[dict]:
        if (self.folder / "cases").is_dir():
            from bridgeflap.design.batch.table import flat_case_rows

            return flat_case_rows(self.case_records())
        if self.kind == "study":
            return [{"analysis": name, "status": _status_text(status)}
                    for name, status in self.statuses().items()]
        tables = sorted(self.folder.glob("*.csv"))
        if tables:
            import pandas as pd

            return pd.read_csv(tables[0]).to_dict("records")
        raise TypeError(f"a {self.kind} folder has no table")

    def to_xarray(self):
        """DOE and batch folders: the cases (:func:`bridgeflap.design.batch.table.cases_dataset`); a
        study: its labelled arrays merged over the analyses' ``results/*.nc`` (variables prefixed
        ``<analysis>.``).

        Returns
        -------
        xarray.Dataset
            The cases on the dimension ``case``, or the study's arrays; a folder with neither:
            its table on the dimension ``row``.

        Raises
        ------
        BridgeflapInputError
            A case or array file cannot be read.
        """
        if (self.folder / "cases").is_dir():
            from bridgeflap.design.batch.table import cases_dataset

            return cases_dataset(self.case_records())
        import xarray as xr

        parts = []
        for path in sorted((self.folder / "results").glob("*.nc")):
            ds = self.dataset(path.stem)
            parts.append(ds.rename({v: f"{path.stem}.{v}" for v in ds.data_vars})
                         .rename({d: f"{path.stem}.{d}" for d in ds.dims}))
        return xr.merge(parts, combine_attrs="drop") if parts else super().to_xarray()

    def _doe_definition(self) -> dict:
        """The DOE definition the folder records (``doe.json``), or ``{}``."""
        path = self.folder / "doe.json"
        if not path.is_file():
            return {}
        try:
            return json.loads(path.read_text("utf-8"))
        except (OSError, ValueError):
            return {}

    def _input_names(self, rows) -> list[str]:
        """The numeric inputs to plot over: a DOE's parameters in their definition's order,
        else (a batch) the case inputs that are numbers in every case; ``[]`` when none."""
        names = list(self._doe_definition().get("parameters") or ())
        if not names and rows:
            names = [k for k in rows[0].get("params", {})
                     if all(isinstance(r.get("params", {}).get(k), int | float)
                            and not isinstance(r["params"][k], bool) for r in rows)]
        return names

    def plot(self, ax=None, output: str | None = None):
        """The folder's figure.

        A DOE folder: an output over its first two inputs, as
        :meth:`bridgeflap.design.studies.experiments.DoeResult.plot` draws it; a batch folder:
        over its first two numeric inputs (over the case number when it has none); other folders:
        their first figure (``figures/*.png``, or ``*.png``) shown as an image.

        Parameters
        ----------
        ax : matplotlib.axes.Axes, optional
            Axis to draw on (default: a new figure).
        output : str, optional
            DOE and batch folders: the result key to show (default: the first numeric one).

        Returns
        -------
        matplotlib.figure.Figure
            The figure.

        Raises
        ------
        TypeError
            A folder with no cases and no figure.
        """
        import matplotlib.pyplot as plt

        if (self.folder / "cases").is_dir():
            from types import SimpleNamespace

            from bridgeflap.design.batch.plots import batch_cases, cases_over_inputs

            rows = self.case_records()
            names = self._input_names(rows)
            if names:  # a DOE: over its inputs, as DoeResult.plot draws it
                name = self._doe_definition().get("name") or self.folder.name
                ok = sum(r.get("status") == "ok" for r in rows)
                return cases_over_inputs(rows, names, ax, output,
                                         title=f"{name}: {ok}/{len(rows)} cases ok")
            failed = sum(r.get("status") != "ok" for r in rows)
            return batch_cases(SimpleNamespace(rows=rows, cases=len(rows), failed=failed),
                               ax, output)
        images = sorted((self.folder / "figures").glob("*.png")) or sorted(
            self.folder.glob("*.png"))
        if not images:
            raise TypeError(f"a {self.kind} folder has no figure")
        if ax is None:
            _, ax = plt.subplots(figsize=(8, 5))
        ax.imshow(plt.imread(images[0]))
        ax.set_axis_off()
        ax.set_title(images[0].name)
        return ax


def _status_text(status: Any) -> str:
    if isinstance(status, dict):
        return str(status.get("status", status))
    return str(status)


def open_run(folder: str | os.PathLike) -> RunRecord:
    """Read a run folder that ``bridgeflap study``, ``doe``, ``sensitivity --global`` or
    ``optimise --out`` (or their Python functions) wrote, without re-running anything.

    Parameters
    ----------
    folder : str or path-like
        The run's output folder.

    Returns
    -------
    RunRecord
        ``kind``, ``summary()``, ``to_dataframe()`` (a DOE's table; a study's statuses),
        ``to_xarray()``, ``table()``, ``plot()``, and the folder's parts: ``results()``,
        ``statuses()``, ``case_records()``, ``controller()``, ``dataset(analysis)``,
        ``files()``.

    Raises
    ------
    BridgeflapInputError
        ``folder``: missing, or not a bridgeflap output folder (no marker).

    Examples
    --------
    >>> run = open_run("runs/humber/output")          # doctest: +SKIP
    >>> run.kind, run.statuses()["flutter"]           # doctest: +SKIP
    """
    from bridgeflap.design.io.outputs import read_marker
    from bridgeflap.model.arguments import check_path

    path = Path(check_path(folder, "folder"))
    if not path.is_dir():
        raise BridgeflapInputError("folder", f"no such folder: {path}")
    marker = read_marker(path)
    if marker is None:
        raise BridgeflapInputError("folder", f"{path} is not a bridgeflap output folder (no "
                                             f".bridgeflap-output marker)")
    data: dict = {}
    for name in ("summary.json", "batch.json"):
        if (path / name).is_file():
            data = _read_json(path / name, "folder")
            break
    if not data and (path / "cases").is_dir():  # interrupted before batch.json was written
        records = [_read_json(p, "folder") for p in sorted((path / "cases").glob("*.json"))]
        ok = sum(r.get("status") == "ok" for r in records)
        data = {"cases": len(records), "succeeded": ok, "failed": len(records) - ok,
                "complete": False}
    return RunRecord(folder=path.resolve(), kind=str(marker.get("kind", "unknown")),
                     marker=marker, data=data)
