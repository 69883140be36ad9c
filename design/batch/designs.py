"""Designs of experiments: full factorial, Latin hypercube and scrambled Sobol' samples.

A design is a list of *cases*: flat dicts of parameter values with a stable ``case_id``
(``case-0000`` ...), ready for the batch runner :func:`bridgeflap.design.batch.runner.run_batch`. No
physics here.
"""

from __future__ import annotations

import inspect
import itertools
import math
import warnings
from collections.abc import Callable, Iterable, Mapping, Sequence
from typing import Any

import numpy as np

from bridgeflap.model.arguments import check_text, checked
from bridgeflap.model.errors import BridgeflapInputError

__all__ = [
    "CASE_ID_KEY",
    "DESIGN_KINDS",
    "full_factorial",
    "latin_hypercube",
    "make_design",
    "sobol",
]

#: key of the case id in a case dict (reserved: not a parameter name)
CASE_ID_KEY = "case_id"


def _case_ids(n: int) -> list[str]:
    """Stable, sortable ids ``case-0000`` ... (at least four digits)."""
    width = max(4, len(str(n - 1)))
    return [f"case-{i:0{width}d}" for i in range(n)]


def _check_name(name: Any, field: str) -> None:
    if not isinstance(name, str) or not name:
        raise BridgeflapInputError(
            field, f"parameter names must be non-empty strings, got {name!r}"
        )
    if name == CASE_ID_KEY:
        raise BridgeflapInputError(field, f"{CASE_ID_KEY!r} is reserved and cannot be a parameter")


def _check_n(n: Any) -> int:
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)):
        raise BridgeflapInputError("n", f"number of cases must be an integer, got {n!r}")
    if n < 1:
        raise BridgeflapInputError("n", f"number of cases must be at least 1, got {n}")
    return int(n)


def _check_seed(seed: Any) -> int:
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise BridgeflapInputError("seed", f"seed must be a non-negative integer, got {seed!r}")
    return int(seed)


def _check_ranges(ranges: Any) -> tuple[list[str], np.ndarray, np.ndarray]:
    """Validate ``{name: (lo, hi)}``; return names, lower and upper bounds."""
    if not isinstance(ranges, Mapping) or not ranges:
        raise BridgeflapInputError("ranges", "at least one parameter range {name: (lo, hi)} needed")
    names, lows, highs = [], [], []
    for name, bounds in ranges.items():
        field = f"ranges.{name}"
        _check_name(name, field)
        try:
            lo, hi = (float(b) for b in bounds)
        except (TypeError, ValueError):
            raise BridgeflapInputError(field, f"expected (lo, hi), got {bounds!r}") from None
        if not (math.isfinite(lo) and math.isfinite(hi)):
            raise BridgeflapInputError(field, f"bounds must be finite, got ({lo}, {hi})")
        if lo >= hi:
            raise BridgeflapInputError(field, f"lower bound {lo} must be below upper bound {hi}")
        names.append(name)
        lows.append(lo)
        highs.append(hi)
    return names, np.array(lows), np.array(highs)


def _rng_kwarg(engine: type, seed: int) -> dict:
    """Seed keyword of a ``scipy.stats.qmc`` engine (``rng`` from SciPy 1.15, else ``seed``)."""
    generator = np.random.default_rng(seed)
    params = inspect.signature(engine).parameters
    return {"rng": generator} if "rng" in params else {"seed": generator}


def _box(ranges, n, seed, engine: type):
    """Checked names, bounds and size of a sampled design, and the engine's seed keyword."""
    names, lo, hi = _check_ranges(ranges)
    n = _check_n(n)
    return names, lo, hi, n, _rng_kwarg(engine, _check_seed(seed))


def _scaled_cases(names: list[str], unit: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> list:
    points = lo + unit * (hi - lo)
    # rounding in lo + u*(hi - lo) may step a hair outside [lo, hi]; clip to the stated bounds
    points = np.clip(points, lo, hi)
    return [
        {CASE_ID_KEY: cid, **{name: float(v) for name, v in zip(names, row, strict=True)}}
        for cid, row in zip(_case_ids(len(points)), points, strict=True)
    ]


def full_factorial(levels: Mapping[str, Sequence]) -> list[dict]:
    """All combinations of the given parameter levels.

    Parameters
    ----------
    levels : mapping of str to sequence
        Parameter name -> its levels (any JSON-serialisable values, in the parameter's unit).

    Returns
    -------
    list of dict
        ``prod(len(v))`` cases ``{"case_id": "case-0000", name: level, ...}``; the last
        parameter varies fastest (``itertools.product`` order), so ids are stable for a given
        ``levels``.
    """
    if not isinstance(levels, Mapping) or not levels:
        raise BridgeflapInputError("levels", "at least one parameter with its levels needed")
    names, values = [], []
    for name, vals in levels.items():
        _check_name(name, f"levels.{name}")
        if isinstance(vals, (str, bytes)) or not isinstance(vals, Iterable):
            raise BridgeflapInputError(f"levels.{name}", f"expected a list of levels, got {vals!r}")
        vals = list(vals)
        if not vals:
            raise BridgeflapInputError(f"levels.{name}", "no levels given")
        names.append(name)
        values.append(vals)
    combos = list(itertools.product(*values))
    return [
        {CASE_ID_KEY: cid, **dict(zip(names, combo, strict=True))}
        for cid, combo in zip(_case_ids(len(combos)), combos, strict=True)
    ]


def latin_hypercube(ranges: Mapping[str, tuple[float, float]], n: int, seed: int) -> list[dict]:
    """Latin hypercube sample of ``n`` cases in a box.

    Parameters
    ----------
    ranges : mapping of str to (float, float)
        Parameter name -> (lower, upper) bound, in the parameter's unit; lower < upper.
    n : int
        Number of cases (>= 1).
    seed : int
        Seed of the random generator; the same seed gives the same cases.

    Returns
    -------
    list of dict
        ``n`` cases; in every parameter each of the ``n`` equal strata of [lo, hi] holds
        exactly one case.

    Notes
    -----
    Uses :class:`scipy.stats.qmc.LatinHypercube` (McKay, Beckman & Conover 1979).
    """
    from scipy.stats import qmc

    names, lo, hi, n, rng = _box(ranges, n, seed, qmc.LatinHypercube)
    engine = qmc.LatinHypercube(d=len(names), **rng)
    return _scaled_cases(names, engine.random(n), lo, hi)


def sobol(ranges: Mapping[str, tuple[float, float]], n: int, seed: int) -> list[dict]:
    """Scrambled Sobol' sample of ``n`` cases in a box.

    Parameters
    ----------
    ranges, n, seed
        As for :func:`latin_hypercube`; ``seed`` seeds the scrambling. A power of two ``n``
        keeps the balance properties of the sequence (the first ``2**m`` points form a
        (t, m, d)-net); other ``n`` are allowed and simply take the first ``n`` points.

    Returns
    -------
    list of dict
        ``n`` cases.

    Notes
    -----
    Uses :class:`scipy.stats.qmc.Sobol` with Owen-type scrambling (Sobol' 1967; Owen 1998).
    SciPy's warning about non-power-of-two sizes is suppressed locally because here it is a
    deliberate choice.
    """
    from scipy.stats import qmc

    names, lo, hi, n, rng = _box(ranges, n, seed, qmc.Sobol)
    engine = qmc.Sobol(d=len(names), scramble=True, **rng)
    if n & (n - 1) == 0:
        unit = engine.random_base2(m=n.bit_length() - 1)
    else:
        with warnings.catch_warnings():
            warnings.filterwarnings(
                "ignore", message=".*balance properties.*", category=UserWarning
            )
            unit = engine.random(n)
    return _scaled_cases(names, unit, lo, hi)


DESIGN_KINDS: dict[str, Callable[..., list[dict]]] = {
    "full_factorial": full_factorial,
    "latin_hypercube": latin_hypercube,
    "sobol": sobol,
}


@checked(kind=check_text)
def make_design(kind: str, **options: Any) -> list[dict]:
    """Build a design by name, e.g. from a run configuration.

    Parameters
    ----------
    kind : str
        One of ``"full_factorial"``, ``"latin_hypercube"``, ``"sobol"``.
    **options
        The keyword arguments of that design function (``levels``; or ``ranges``, ``n``,
        ``seed``).

    Returns
    -------
    list of dict
        The cases.

    Examples
    --------
    >>> from bridgeflap import design
    >>> cases = design.make_design("full_factorial", levels={"deck.gj_nm2": [4.7e11, 7.1e11],
    ...                                                      "cable.main_sag_m": [110.0, 125.0]})
    >>> len(cases), cases[0]["case_id"]
    (4, 'case-0000')
    """
    if kind not in DESIGN_KINDS:
        known = ", ".join(sorted(DESIGN_KINDS))
        canonical = str(kind).replace("-", "_") if isinstance(kind, str) else None
        if canonical in DESIGN_KINDS:  # the spelling of DOE files of earlier versions
            raise BridgeflapInputError("kind", f"{kind!r} is spelled {canonical!r} "
                                               "(docs/api_vocabulary.md)")
        raise BridgeflapInputError("kind", f"unknown design kind {kind!r} (known: {known})")
    func = DESIGN_KINDS[kind]
    params = inspect.signature(func).parameters
    for key in options:
        if key not in params:
            raise BridgeflapInputError(key, f"not an option of the {kind} design")
    for key, par in params.items():
        if par.default is inspect.Parameter.empty and key not in options:
            raise BridgeflapInputError(key, f"required by the {kind} design")
    return func(**options)
