"""Branch-switch flags for DOE and sensitivity rows (docs/methods.md#stability).

Under a small change of an input the critical branch can hop between modes (TS1 to VS3, or to a
side-span hybrid) and the flutter speed jumps; a derivative or a response surface fitted across
such a switch is meaningless. :func:`flag_branch_neighbours` marks every row whose neighbours in
parameter space have a different ``critical_branch_label``:

* **factorial designs** (every parameter takes a few levels and the rows are a full or partial
  grid on them): the neighbours of a row are the rows one level away in exactly one parameter,
  the others held at the same level;
* **any other design** (Latin hypercube, Sobol', random): the ``k`` nearest rows in parameter
  space normalised to the unit cube (each parameter divided by its range over the rows).

Pure function of the rows: no model, no file. The DOE runner (:mod:`bridgeflap.design.batch.runner`)
adds the flags to its rows.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

__all__ = ["DEFAULT_K", "flag_branch_neighbours"]

#: neighbours of a row in a non-factorial design (one per side in two dimensions)
DEFAULT_K = 4
_LABEL = "critical_branch_label"


def _values(rows: Sequence[Mapping], param_keys: Sequence[str]) -> np.ndarray:
    try:
        x = np.array([[float(r[k]) for k in param_keys] for r in rows], dtype=float)
    except KeyError as exc:
        raise KeyError(f"row without parameter {exc.args[0]!r}") from None
    return x.reshape(len(rows), len(param_keys))


def _is_factorial(levels: list[np.ndarray], n_rows: int) -> bool:
    """Grid-like: every parameter has at most ``max(2, n_rows // 2)`` levels, so each level is
    shared by at least two rows on average (a scattered design has as many values as rows)."""
    if n_rows < 2:
        return False
    return all(len(lv) <= max(2, n_rows // 2) for lv in levels)


def flag_branch_neighbours(rows: Sequence[Mapping], param_keys: Sequence[str],
                           k: int = DEFAULT_K, label_key: str = _LABEL,
                           design: str = "auto") -> list[dict]:
    """Flag rows whose parameter-space neighbours have a different critical branch.

    Parameters
    ----------
    rows : sequence of mapping
        Flat rows (DOE cases, sensitivity points): the parameter values under ``param_keys``
        and the critical branch under ``label_key``. A row whose label is missing or empty
        (no converged crossing, a failed case) is never a witness of a switch and is not
        flagged itself.
    param_keys : sequence of str
        Parameter columns [any units; normalised internally].
    k : int
        Neighbours per row in a non-factorial design.
    label_key : str
        Column of the branch label.
    design : {"auto", "factorial", "scattered"}
        ``"auto"`` treats the rows as factorial when every parameter takes at most
        ``max(2, n_rows // 2)`` distinct values.

    Returns
    -------
    list of dict
        One per row, in order: ``branch_switch_neighbour`` (bool), ``neighbour_branches``
        (sorted labels of the neighbours that differ) and ``neighbour_rows`` (their indices),
        plus ``neighbour_rule`` (``"factorial"`` or ``"k_nearest"``).
    """
    rows = list(rows)
    keys = list(param_keys)
    n = len(rows)
    if design not in ("auto", "factorial", "scattered"):
        raise ValueError(f"design must be auto, factorial or scattered, got {design!r}")
    if n == 0:
        return []
    if not keys:
        raise ValueError("param_keys is empty")
    x = _values(rows, keys)
    labels = [str(r.get(label_key) or "") for r in rows]
    levels = [np.unique(x[:, j]) for j in range(len(keys))]
    factorial = (design == "factorial" or
                 (design == "auto" and _is_factorial(levels, n)))
    neighbours: list[list[int]] = []
    if factorial:
        # level index of every row in every parameter; neighbours differ by one level in one
        # parameter and agree in all the others
        idx = np.column_stack([np.searchsorted(levels[j], x[:, j]) for j in range(len(keys))])
        where = {tuple(r): i for i, r in enumerate(idx)}
        for i in range(n):
            near = []
            for j in range(len(keys)):
                for step in (-1, 1):
                    key = idx[i].copy()
                    key[j] += step
                    hit = where.get(tuple(key))
                    if hit is not None and hit != i:
                        near.append(hit)
            neighbours.append(sorted(set(near)))
    else:
        span = x.max(axis=0) - x.min(axis=0)
        z = (x - x.min(axis=0)) / np.where(span > 0, span, 1.0)
        d = np.linalg.norm(z[:, None, :] - z[None, :, :], axis=2)
        np.fill_diagonal(d, np.inf)
        kk = max(0, min(int(k), n - 1))
        for i in range(n):
            neighbours.append(sorted(int(j) for j in np.argsort(d[i], kind="stable")[:kk]))
    out = []
    for i in range(n):
        differ = [j for j in neighbours[i]
                  if labels[i] and labels[j] and labels[j] != labels[i]]
        out.append({"branch_switch_neighbour": bool(differ),
                    "neighbour_branches": sorted({labels[j] for j in differ}),
                    "neighbour_rows": differ,
                    "neighbour_rule": "factorial" if factorial else "k_nearest"})
    return out
