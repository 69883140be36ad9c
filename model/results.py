"""Results as data: strict-JSON dicts, pandas tables and xarray datasets of every result.

Every result record (:class:`bridgeflap.model.stability.sweeps.StabilitySweep`,
:class:`bridgeflap.model.analysis.FlutterResult`,
:class:`bridgeflap.model.structure.modes.ModalModel`,
:class:`bridgeflap.model.response.buffeting.BuffetingResult`, the design records, ...) mixes in
:class:`ResultData` and so has

* ``to_dict()`` -- plain JSON types with units in the key names; NaN and +-inf become ``None``
  (strict JSON, RFC 8259), numpy scalars and arrays Python numbers and lists
  (:func:`jsonable`);
* ``to_dataframe()`` -- a :class:`pandas.DataFrame` for anything tabular, every numeric column
  named with its unit (``speed_m_s``, ``frequency_hz``, ``damping_ratio``, ``real_part_1_s``);
* ``table(fmt)`` -- that frame as text (:mod:`tabulate`; ``"github"`` Markdown by default);
* ``summary()`` -- the headline numbers in plain Python types (``float``, ``int``, ``str``,
  ``None``, lists and dicts of them; never a numpy scalar), each also an attribute of the result
  (``result.flutter_speed_m_s``; a misspelt name raises :class:`AttributeError`);
* ``to_xarray()`` -- an :class:`xarray.Dataset` of the labelled data (the table's by default);
* ``plot()`` -- a :class:`matplotlib.figure.Figure`, whatever number of axes it draws.

Sweeps are also ``xarray.Dataset`` objects (:func:`sweep_dataset`: coordinates ``speed_m_s`` and
``branch``, units in ``attrs``), written as NetCDF-3 with xarray's scipy engine
(:func:`bridgeflap.design.io.files.atomic_save_netcdf`; no netCDF4/h5netcdf dependency). pandas,
xarray and tabulate are imported lazily, so importing the model stays cheap.
"""

from __future__ import annotations

import dataclasses
import datetime as _dt
import enum
import math
import os
from collections.abc import Mapping
from typing import Any

import numpy as np

__all__ = ["REPR_LIMIT", "ResultData", "UNITLESS_COLUMNS", "figure_of", "finite_extreme",
           "jsonable", "plain", "sweep_dataset", "strict_json", "sweep_frame", "table_text"]

#: Column names that carry no unit because they are labels, statuses or counts.
UNITLESS_COLUMNS = frozenset({
    "label", "branch", "family", "symmetry", "span", "status", "stage", "parameter", "case_id",
    "error", "mechanism", "critical_mechanism", "critical_branch_label", "flutter_status",
    "divergence_status", "flutter_onset", "second_critical_branch_label",
    "second_flutter_status", "grid_points", "start", "order", "kind", "method", "bridge",
    "name", "chosen", "placement", "flap_count", "iterations",
})

#: Suffixes that name a unit (or say "dimensionless": ``_ratio``, ``_share``, ``_rel``, ...).
UNIT_SUFFIXES = ("_m_s", "_hz", "_1_s", "_m", "_rad", "_s", "_ratio", "_share", "_per_unit",
                 "_over_width", "_rel", "_kg", "_kg_m", "_n", "_nm", "_deg", "_rad_s",
                 "_per_m", "_s_per_m", "_fraction", "_gain", "_margin", "_count", "_status",
                 "_label", "_flag", "_ok", "_holds", "_index", "_convergence")


def jsonable(obj: Any) -> Any:
    """``obj`` in plain JSON types; NaN/inf -> ``None``
    (:func:`bridgeflap.design.io.files.to_jsonable`).

    Numpy scalars become Python scalars, arrays nested lists, dataclasses dicts of their fields
    (or their ``to_dict()``), paths strings, enums their value, dates ISO strings, complex
    numbers ``{"real": x, "imag": y}`` and mapping keys strings.

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
        return {"real": jsonable(value.real), "imag": jsonable(value.imag)}
    if isinstance(obj, np.ndarray):
        return [jsonable(item) for item in obj.tolist()] if obj.ndim else jsonable(obj[()])
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        return {f.name: jsonable(getattr(obj, f.name)) for f in dataclasses.fields(obj)}
    if isinstance(obj, Mapping):
        return {k if isinstance(k, str) else str(jsonable(k)): jsonable(v)
                for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [jsonable(item) for item in obj]
    if isinstance(obj, (set, frozenset)):
        return [jsonable(item) for item in sorted(obj, key=repr)]
    if isinstance(obj, os.PathLike):
        return os.fspath(obj)
    if isinstance(obj, enum.Enum):
        return jsonable(obj.value)
    if isinstance(obj, (_dt.datetime, _dt.date, _dt.time)):
        return obj.isoformat()
    raise TypeError(f"cannot convert an object of type {type(obj).__name__} to JSON")


def plain(obj: Any) -> Any:
    """``obj`` with every numpy scalar a Python scalar, inside dicts, lists and tuples too.

    Unlike :func:`jsonable` it keeps NaN a float NaN and leaves arrays and other objects as they
    are: what ``summary()`` returns (a ``np.float64`` prints as ``np.float64(69.5)`` and is not
    a ``float`` to every library).
    """
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, dict):
        return {k: plain(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple) and not hasattr(obj, "_fields"):
        return type(obj)(plain(v) for v in obj)
    return obj


def figure_of(drawn: Any):
    """The :class:`matplotlib.figure.Figure` of what a plot drew: a figure, an axes, or an
    array, list or tuple of axes (their first one's figure)."""
    if hasattr(drawn, "savefig"):
        return drawn
    if isinstance(drawn, list | tuple | np.ndarray):
        return figure_of(np.ravel(np.asarray(drawn, dtype=object))[0])
    figure = getattr(drawn, "figure", None)
    if figure is None:
        raise TypeError(f"not a figure or axes: {type(drawn).__name__}")
    return figure


def _plain_summary(method):
    import functools

    @functools.wraps(method)
    def summary(self, *args, **kwargs):
        return plain(method(self, *args, **kwargs))

    summary._plain = True
    return summary


def _figure_plot(method):
    import functools

    @functools.wraps(method)
    def plot(self, *args, **kwargs):
        return figure_of(method(self, *args, **kwargs))

    plot._figure = True
    if plot.__doc__ and "Returns\n" not in plot.__doc__:  # a numpydoc one says it already
        plot.__doc__ = plot.__doc__.rstrip() + "\n\n(Returns the matplotlib Figure.)"
    return plot


def strict_json(method):
    """Decorator: the method's return value through :func:`jsonable` (strict JSON)."""
    import functools

    @functools.wraps(method)
    def wrapper(*args, **kwargs):
        return jsonable(method(*args, **kwargs))

    return wrapper


def table_text(frame, fmt: str = "github", floatfmt: str = ".6g") -> str:
    """A :class:`pandas.DataFrame` as a text table (:func:`tabulate.tabulate`); NaN -> blank."""
    from tabulate import tabulate

    return tabulate(frame, headers="keys", tablefmt=fmt, floatfmt=floatfmt, showindex=False,
                    missingval="")


#: longest ``repr`` of a result [characters] (a notebook shows it whole: under 2 kB)
REPR_LIMIT = 2000
_VALUE_LIMIT = 60  # characters of one headline value in the repr


def _is_scalar(v) -> bool:
    return v is None or isinstance(v, (bool, int, float, str, np.generic))


def finite_extreme(values, lowest: bool = False) -> float | None:
    """Largest (``lowest``: smallest) finite entry of ``values``; None when none is finite."""
    a = np.asarray(values, float).ravel()
    a = a[np.isfinite(a)]
    return None if not a.size else float(a.min() if lowest else a.max())


def _short(v, limit: int = _VALUE_LIMIT) -> str:
    """One headline value as short text: floats to 6 significant digits, long text cut."""
    if isinstance(v, (float, np.floating)):
        text = f"{float(v):.6g}"
    elif isinstance(v, str):
        text = repr(v)
    else:
        text = str(v)
    return text if len(text) <= limit else text[: limit - 3] + "..."


class ResultData:
    """Mixin of every result record: ``to_dict``, ``to_dataframe``, ``table``, and the notebook
    views ``__repr__``, ``_repr_html_`` and ``plot``.

    ``to_dict`` is the record's ``summary()`` (its JSON contract) when it has one, else its
    fields, made strict-JSON by :func:`jsonable`. Tabular records override
    :meth:`_rows` (a list of flat dicts with units in the keys) or :meth:`to_dataframe`.

    ``repr`` and ``_repr_html_`` show :meth:`_headline`: the summary's scalar entries named in
    ``_HEADLINE_KEYS`` (every scalar entry when it is empty), a few numbers and the status,
    never the arrays (``repr`` stays under :data:`REPR_LIMIT` characters). ``plot(ax=None)``
    draws the result and returns its axes (matplotlib imported there, never ``plt.show()``).
    """

    #: summary keys shown by ``repr`` and the HTML table, in order (empty: every scalar entry)
    _HEADLINE_KEYS: tuple = ()

    def __init_subclass__(cls, **kwargs):
        super().__init_subclass__(**kwargs)
        # one face for every result: summary() in plain Python types, plot() a Figure
        own = cls.__dict__
        if callable(own.get("summary")) and not getattr(own["summary"], "_plain", False):
            cls.summary = _plain_summary(own["summary"])
        if callable(own.get("plot")) and not getattr(own["plot"], "_figure", False):
            cls.plot = _figure_plot(own["plot"])
        # @dataclass writes a field-by-field __repr__ (165 kB for a FlutterResult: every
        # eigenvalue) unless the class defines one itself: give each subclass the short one
        if "__repr__" not in cls.__dict__:
            cls.__repr__ = ResultData.__repr__

    def _headline(self) -> dict:
        """The few numbers and statuses that say what the result is (scalars of the summary)."""
        summary = getattr(self, "summary", None)
        d = summary() if callable(summary) else self.to_dict()
        keys = self._HEADLINE_KEYS or tuple(d)
        return {k: d[k] for k in keys if k in d and _is_scalar(d[k])}

    def _headline_safe(self) -> dict:
        # a view must not raise in a notebook: a result that cannot summarise itself says so
        try:
            return self._headline()
        except Exception as exc:  # shown, not hidden: the error is the view
            return {"summary_error": f"{type(exc).__name__}: {exc}"}

    def __repr__(self) -> str:
        items = ", ".join(f"{k}={_short(v)}" for k, v in self._headline_safe().items())
        text = f"{type(self).__name__}({items})"
        return text if len(text) <= REPR_LIMIT else text[: REPR_LIMIT - 4] + "...)"

    def _repr_html_(self) -> str:
        """The headline as a small HTML table (escaped; what Jupyter shows for the result)."""
        import html

        rows = "".join(f"<tr><th style='text-align:left'>{html.escape(str(k))}</th>"
                       f"<td style='text-align:left'>{html.escape(_short(v, 120))}</td></tr>"
                       for k, v in self._headline_safe().items())
        return (f"<table><caption>{html.escape(type(self).__name__)}</caption>"
                f"<tbody>{rows}</tbody></table>")

    def plot(self, ax=None, **kwargs):
        """Draw the result on ``ax`` (new figure when None); returns the Figure."""
        raise TypeError(f"{type(self).__name__} has nothing to plot")

    def __getattr__(self, name: str):
        # only for names no attribute, field or method has: the summary's scalar entries
        if name.startswith("_"):
            raise AttributeError(name)
        summary = type(self).__dict__.get("summary") or getattr(type(self), "summary", None)
        if callable(summary):
            values = summary(self)
            if name in values and _is_scalar(values[name]):
                return values[name]
        raise AttributeError(f"{type(self).__name__!r} object has no attribute {name!r} "
                             f"(headline numbers: {', '.join(self._headline_names()) or 'none'})")

    def _headline_names(self) -> list[str]:
        summary = getattr(type(self), "summary", None)
        if not callable(summary):
            return []
        try:
            return [k for k, v in summary(self).items() if _is_scalar(v)]
        except Exception:  # a view must not raise: no names then
            return []

    def __dir__(self):
        return sorted(set(super().__dir__()) | set(self._headline_names()))

    def to_xarray(self):
        """The result's table as an :class:`xarray.Dataset` (one ``row`` per table row);
        labelled results override it with their own coordinates.

        Returns
        -------
        xarray.Dataset
            The table's columns as variables on the dimension ``row`` (units in the names).
        """
        import xarray as xr

        return xr.Dataset.from_dataframe(self.to_dataframe().rename_axis("row"))

    def to_dict(self) -> dict:
        """Strict-JSON dict (units in the key names, NaN/inf as ``None``).

        Returns
        -------
        dict
            :meth:`summary` through strict JSON when the result has one, else its displayed
            fields.

        Raises
        ------
        TypeError
            The result holds no data to convert.
        """
        summary = getattr(self, "summary", None)
        if callable(summary):
            return jsonable(summary())
        if dataclasses.is_dataclass(self):
            return {f.name: jsonable(getattr(self, f.name)) for f in dataclasses.fields(self)
                    if f.repr}
        raise TypeError(f"{type(self).__name__} has no data to convert")

    def _rows(self) -> list[dict]:
        raise TypeError(f"{type(self).__name__} is not tabular")

    def to_dataframe(self):
        """Table of the result (:class:`pandas.DataFrame`), one unit-named column per quantity.

        Returns
        -------
        pandas.DataFrame
            One row per record of the result.

        Raises
        ------
        TypeError
            The result is not tabular.
        """
        import pandas as pd

        return pd.DataFrame(self._rows())

    def table(self, fmt: str = "github") -> str:
        """:meth:`to_dataframe` as text (``fmt``: any :mod:`tabulate` format).

        Parameters
        ----------
        fmt : str, default "github"
            A :mod:`tabulate` table format (``"github"``, ``"simple"``, ``"latex"``, ...).

        Returns
        -------
        str
            The table, NaN shown blank.
        """
        return table_text(self.to_dataframe(), fmt)


# ------------------------------------------------------------------------------- sweeps
_SWEEP_UNITS = {"frequency_hz": "Hz", "damping_ratio": "1", "real_part_1_s": "1/s",
                "imag_part_1_s": "1/s"}


def _sweep_fields(sweep) -> dict:
    lam = np.asarray(sweep.branches)
    with np.errstate(invalid="ignore", divide="ignore"):
        zeta = -lam.real / np.abs(lam)
    return {"frequency_hz": np.abs(lam.imag) / (2 * np.pi), "damping_ratio": zeta,
            "real_part_1_s": lam.real, "imag_part_1_s": lam.imag}


def sweep_frame(sweep):
    """Long table of a :class:`~bridgeflap.model.stability.sweeps.StabilitySweep`: one row per speed
    x branch.

    Columns ``speed_m_s``, ``branch`` (its label at U = 0), ``frequency_hz``,
    ``damping_ratio`` [-], ``real_part_1_s`` and ``imag_part_1_s`` [1/s].
    """
    import pandas as pd

    u = np.asarray(sweep.speeds, float)
    labels = list(sweep.branch_labels)
    fields = _sweep_fields(sweep)
    data = {"speed_m_s": np.tile(u, len(labels)), "branch": np.repeat(labels, u.size)}
    data.update({k: v.reshape(-1) for k, v in fields.items()})
    return pd.DataFrame(data)


def sweep_dataset(sweep, attrs: Mapping | None = None):
    """The tracked branches of a sweep as an :class:`xarray.Dataset`.

    Coordinates ``speed_m_s`` [m/s] and ``branch`` (label); variables ``frequency_hz``,
    ``damping_ratio``, ``real_part_1_s``, ``imag_part_1_s`` on ``(branch, speed_m_s)``, each
    with ``attrs["units"]``; the dataset attrs hold the flutter and divergence numbers
    (strict: NaN kept as NaN, which NetCDF stores).
    """
    import xarray as xr

    fields = _sweep_fields(sweep)
    ds = xr.Dataset(
        {k: (("branch", "speed_m_s"), v, {"units": _SWEEP_UNITS[k]}) for k, v in fields.items()},
        coords={"speed_m_s": ("speed_m_s", np.asarray(sweep.speeds, float), {"units": "m/s"}),
                "branch": ("branch", np.asarray(list(sweep.branch_labels), dtype=str))})
    meta = {"flutter_speed_m_s": float(sweep.flutter.speed),
            "flutter_frequency_hz": float(sweep.flutter.frequency_hz),
            "flutter_status": str(sweep.flutter.status),
            "divergence_speed_m_s": float(sweep.divergence.speed),
            "divergence_status": str(sweep.divergence.status),
            "critical_branch_label": str(sweep.critical_branch or "")}
    meta.update({k: (v if isinstance(v, (str, int, float)) else str(v))
                 for k, v in (attrs or {}).items()})
    ds.attrs.update(meta)
    return ds
