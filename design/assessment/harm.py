"""Do no harm: a controller judged on bridges it was not designed on.

For each of ``count`` fresh variants drawn (independent uniform draws by default, the basis of
the Clopper-Pearson certificate; Sobol' points, :func:`bridgeflap.design.batch.designs.sobol`, on
request, with no such bound) over the uncertainty set of the estimated inputs
(:data:`bridgeflap.design.control.uncertainty.DEFAULT_UNCERTAIN_RANGES` less the inputs held fixed),
the variant's **open-loop** critical speed (flutter or divergence, whichever comes first) is set
against its **closed-loop** one with the controller's flaps, both from the same sweep on the same
grid and mode count (:func:`bridgeflap.model.analysis.closed_loop_flutter`).

A variant is *harmed* when the closed loop goes unstable below the open loop's critical speed
(by more than :data:`HARM_TOL_REL`: Brent stops each crossing at 1e-3 m/s, so a smaller
difference is the same speed). A crossing that is neither converged nor absent from the grid
(``unverified_crossing``, ``bracket_failed``, ``unstable_at_first_speed``) and whose grid
bracket does not lie above the converged critical speed makes its row ``unresolved``: it is
counted apart, never as a pass. A speed beyond the grid is reported as
``null`` with ``*_beyond_grid`` true (a lower bound: the grid's last speed).

The summary gives the fraction stable to the design speed, the fraction harmed, the worst
closed/open ratio and the worst variant; the rows are a table (``to_dataframe``).

``method`` (:data:`HARM_METHODS`): ``"reference"`` is the full fast sweep of each loop
(:func:`bridgeflap.model.stability.sweeps.sweep`, ``method="fast"``: labels confirmed, the
second-critical branch, the whole dense sweep where Newton is unsure); ``"fast"`` (the default)
reads the same crossings with ``critical_only`` (no labels, no second branch, a crossing Newton
misses kept from its 0.5 m/s grid bracket) on a modal model that solves only the retained modes'
labels. The verdict reads nothing else, so both give the same rows to the crossings'
tolerance (docs/methods.md#fast-do-no-harm-check; tests/test_harm_fast.py).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

# the verdict of one row, also served from here
from bridgeflap.design.assessment.harm_verdict import (
    HARM_TOL_REL,
    SCREEN_MARGIN_REL,
    _crit,
    _row,
    near_decision,
)
from bridgeflap.design.io.api_args import MAX_VARIANTS
from bridgeflap.model.errors import BridgeflapInputError
from bridgeflap.model.progress import Eta
from bridgeflap.model.results import ResultData

__all__ = ["DEFAULT_SCREEN_MODES", "HARM_METHODS", "HARM_TOL_REL", "MAX_VARIANTS", "SAMPLINGS",
           "SCREEN_MARGIN_REL", "HarmResult", "clopper_pearson_upper", "do_no_harm",
           "harm_bound_text", "harm_row", "near_decision"]

#: most fresh variants of one check (``count``): :data:`bridgeflap.design.io.api_args.MAX_VARIANTS`,
#: the bound of every count of fresh variants, CLI and API alike
#: ``method`` of :func:`do_no_harm` and :func:`harm_row`: ``"fast"`` (default) or the
#: ``"reference"`` (the module docstring)
HARM_METHODS = ("fast", "reference")

#: the largest 16-vs-30 change seen on the recomputed rows must stay below this fraction of
#: the margin, else every screened row is recomputed (the screening is not trusted)
SCREEN_CHECK_FRACTION = 1 / 3
#: modes of the fast method's screening (model.analysis.DEFAULT_MODES' 16-mode count)
DEFAULT_SCREEN_MODES = 16
#: inputs held at their nominal value: the half-chord is a reading of the geometry, not an
#: uncertainty of one bridge (the flap chord and positions are fixed to it), and the coherence
#: decay enters buffeting only
DEFAULT_FIXED = ("deck.half_chord_m", "aero.coherence_decay")


#: ``sampling`` of :func:`do_no_harm`: ``"random"`` (the default: independent uniform draws, the
#: basis of the Clopper-Pearson certificate of :func:`clopper_pearson_upper`) or ``"sobol"``
#: (scrambled Sobol', even coverage of the box, as the design's scenarios and the screening; no
#: certificate)
SAMPLINGS = ("random", "sobol")


def harm_bound_text(sampling: str) -> str:
    """What ``harm_probability_upper_95`` of a check drawn by ``sampling`` is (or why there is
    none)."""
    if sampling == "random":
        return ("one-sided 95 % Clopper-Pearson upper bound on the probability that a bridge "
                "drawn from the ranges is harmed (independent draws: sampling 'random')")
    return ("none: the variants are Sobol' points (sampling 'sobol'), not independent draws, "
            "so the count of harmed variants gives no Clopper-Pearson certificate; draw them "
            "with sampling 'random' for one")


def clopper_pearson_upper(harmed: int, n: int, confidence: float = 0.95) -> float | None:
    """One-sided Clopper-Pearson upper bound [-] on a probability from ``harmed`` events in
    ``n`` independent draws: ``1 - (1 - confidence)^(1/n)`` for 0 events (0.30 % for 0 of
    1000 at 95 %), else the ``confidence`` quantile of Beta(harmed + 1, n - harmed)."""
    if n <= 0:
        return None
    if harmed >= n:
        return 1.0
    if harmed == 0:
        return float(1.0 - (1.0 - confidence) ** (1.0 / n))
    from scipy.stats import beta

    return float(beta.ppf(confidence, harmed + 1, n - harmed))


def _check_method(method) -> None:
    if method not in HARM_METHODS:
        raise BridgeflapInputError("method", f"must be one of {HARM_METHODS}, got {method!r}")


def harm_row(spec, controller, speeds, n_modes: int, speed_max_m_s: float,
             sweep_method: str = "fast", method: str = "reference",
             screen_modes: int | None = None, confirm=None, screened=None) -> dict:
    """One variant's open- and closed-loop critical speeds and the harm verdict.

    ``method``: :data:`HARM_METHODS`. ``"fast"``:
    :func:`bridgeflap.design.assessment.harm_fast.fast_row` (screened on ``screen_modes`` when below
    ``n_modes``; ``confirm`` the loops to put on ``n_modes`` regardless, ``screened`` an earlier row
    whose screening is reused; ``sweep_method`` is ignored: always the fast sweep,
    ``critical_only``).
    """
    from bridgeflap.model.analysis import closed_loop_flutter

    _check_method(method)
    if method == "fast":
        from bridgeflap.design.assessment.harm_fast import fast_row

        return fast_row(spec, controller, speeds, n_modes, speed_max_m_s, screen_modes,
                        confirm, screened)
    res = closed_loop_flutter(spec, controller, speeds, n_modes, sweep_method=sweep_method,
                              verify_static=False)  # the verdict reads the sweep alone
    crits = {"closed_loop": _crit(res.base.summary()),
             "open_loop": _crit(res.open_loop.summary())}
    return _row(crits, speed_max_m_s, {"open_loop": n_modes, "closed_loop": n_modes})


@dataclass(frozen=True)
class HarmResult(ResultData):
    """The do-no-harm table of one controller over ``count`` fresh variants."""

    bridge: str
    count: int
    n_modes: int
    speed_max_m_s: float
    speeds_max_m_s: float
    seed: int
    ranges: dict
    rows: tuple = field(repr=False)
    method: str = "reference"
    #: modes of the fast method's screening (None: every row on ``n_modes``)
    screen_modes: int | None = None
    #: the a-posteriori check of the screening (:func:`do_no_harm`)
    screen_check: dict = field(default_factory=dict)
    #: how the variants were drawn (:data:`SAMPLINGS`)
    sampling: str = "random"

    def summary(self) -> dict:
        """Fractions, the worst ratio and its variant (strict-JSON ready).

        Returns
        -------
        dict
            ``status`` (``no_harm``, ``harm`` or ``unresolved``), the variant count, the
            fractions stable to the design speed and harmed [-], the worst closed- over open-loop
            ratio and its variant, the harm-probability bound and the screening check.
        """
        n = max(len(self.rows), 1)
        ratios = [(r["closed_over_open"], i) for i, r in enumerate(self.rows)
                  if r["resolved"] and r["closed_over_open"] is not None]
        worst = min(ratios) if ratios else (None, None)
        harmed = [i for i, r in enumerate(self.rows) if r["harmed"]]
        unresolved = sum(not r["resolved"] for r in self.rows)
        return {
            "bridge": self.bridge, "variants": len(self.rows), "modes": self.n_modes,
            "seed": self.seed, "design_speed_m_s": self.speed_max_m_s,
            "grid_max_m_s": self.speeds_max_m_s,
            "fraction_stable_to_design_speed":
                sum(r["stable_to_design_speed"] for r in self.rows) / n,
            "fraction_harmed": len(harmed) / n, "harmed_variants": harmed,
            "unresolved_variants": unresolved,
            "worst_closed_over_open": worst[0], "worst_variant": worst[1],
            "worst_closed_loop_critical_speed_m_s": min(
                (r["closed_loop_critical_speed_m_s"] for r in self.rows
                 if r["closed_loop_critical_speed_m_s"] is not None), default=None),
            # a harm outranks "unresolved": a harmed variant is never hidden behind another's
            # unverified crossing
            "status": ("harm" if harmed else "unresolved" if unresolved else "no_harm"),
            "harmed_count": len(harmed),
            # a certificate holds for independent draws only: none for Sobol' points
            "harm_probability_upper_95": (clopper_pearson_upper(len(harmed), len(self.rows))
                                          if self.sampling == "random" else None),
            "harm_probability_bound": harm_bound_text(self.sampling),
            "sampling": self.sampling,
            "ranges": {k: list(v) for k, v in self.ranges.items()},
            "method": self.method, "screen_modes": self.screen_modes,
            "variants_on_all_modes": sum(_on(r, self.n_modes) for r in self.rows),
            **({"screen_check": dict(self.screen_check)} if self.screen_check else {}),
        }

    _HEADLINE_KEYS = ("bridge", "variants", "modes", "design_speed_m_s",
                      "fraction_stable_to_design_speed", "fraction_harmed",
                      "worst_closed_over_open", "worst_closed_loop_critical_speed_m_s", "status")

    def plot(self, ax=None):
        """Histogram of the closed- over open-loop critical speed of the variants [-]
        (:func:`bridgeflap.design.control.results.result_plots.harm_ratios`).

        Parameters
        ----------
        ax : matplotlib.axes.Axes, optional
            Axes to draw on (default: a new figure).

        Returns
        -------
        matplotlib.figure.Figure
            The figure drawn on (a new one when no axes are given).
        """
        from bridgeflap.design.control.results.result_plots import harm_ratios

        return harm_ratios(self, ax)

    def to_dataframe(self):
        """One row per variant: its inputs and the verdict (unit-named columns).

        Returns
        -------
        pandas.DataFrame
            Column ``variant``, the drawn inputs, the open- and closed-loop critical speeds
            [m/s] (empty beyond the grid) and mechanisms, ``closed_over_open`` [-],
            ``stable_to_design_speed``, ``harmed``, ``resolved`` and each loop's mode count.
        """
        import pandas as pd

        return pd.DataFrame([{"variant": i, **r} for i, r in enumerate(self.rows)])


def _sample(spec, ranges: dict, count: int, seed: int,
            sampling: str = "sobol") -> list[tuple[dict, object]]:
    if sampling == "random":    # independent uniform draws, inputs in the ranges' order
        rng = np.random.default_rng(int(seed))
        u = rng.random((int(count), len(ranges)))
        cases = [{k: lo + (hi - lo) * float(x) for (k, (lo, hi)), x
                  in zip(ranges.items(), row, strict=True)} for row in u]
    else:
        from bridgeflap.design.batch.designs import sobol

        cases = sobol(ranges, int(count), int(seed))
    return [({k: float(v) for k, v in case.items() if k in ranges},
             spec.replace(**{k: v for k, v in case.items() if k in ranges}))
            for case in cases]


def _rows_of(chunk, controller, speeds, n_modes, speed_max, method="reference",
             screen_modes=None, redo=None):
    """Rows of ``chunk``; ``redo``: ``(loops, earlier row)`` to put those loops on
    ``n_modes`` reusing the earlier row's screening."""
    confirm, screened = redo if redo is not None else (None, None)
    return [{**params, **harm_row(v, controller, speeds, n_modes, speed_max, method=method,
                                  screen_modes=screen_modes, confirm=confirm,
                                  screened=screened and {k: x for k, x in screened.items()
                                                         if k not in params})}
            for params, v in chunk]


def do_no_harm(controller, bridge="humber", count: int = 200, seed: int = 11,
               n_modes: int = 30, speed_max_m_s: float = 85.0, speeds=None,
               ranges: dict | None = None, fixed=DEFAULT_FIXED, workers: int = 1,
               progress=None, method: str = "fast",
               screen_modes: int | None = DEFAULT_SCREEN_MODES,
               sampling: str = "random", scheduler: str | None = None) -> HarmResult:
    """Open- against closed-loop critical speed of ``controller`` on ``count`` fresh variants.

    Parameters
    ----------
    controller : bridgeflap.model.aeroelastic.control.Controller
        The loop (its own flap chord and layout).
    bridge : str or BridgeSpec
        The nominal bridge (built-in name, TOML path, or a spec).
    count, seed : int
        Fresh variants and the seed of their draws (another seed: other variants).
    n_modes : int
        Retained modes of every variant's model (of every row's numbers with
        ``method="reference"`` or ``screen_modes=None``).
    speed_max_m_s : float
        The design speed: "stable to the design speed" is a closed-loop critical speed above it.
    speeds : array, optional
        The sweep grid [m/s]; default ``0 .. 1.5 speed_max`` in 0.5 m/s steps, so that a
        closed loop that lifts the critical speed is still compared, not clipped.
    ranges : dict, optional
        Input path -> (low, high) [SI]; default the estimated-input ranges less ``fixed``.
    workers : int
        Processes (one variant per task); with ``scheduler="local"`` the local Dask
        cluster's workers.
    scheduler : str, optional
        None (default): a local process pool of ``workers`` (serial for 1). ``"local"``: a
        local Dask cluster of ``workers``; an address (``tcp://host:8786``): that Dask
        scheduler's workers, so a cluster spreads a large check (the DOE runner's client,
        :func:`bridgeflap.design.batch.cluster.cluster_client`: one line naming
        ``scheduler`` when it cannot be reached). The rows are the same in every case: each
        variant is one task, independent of where it runs.
    method : {"fast", "reference"}
        :data:`HARM_METHODS` (the module docstring).
    sampling : {"random", "sobol"}
        :data:`SAMPLINGS`: ``"random"`` (default) draws the variants independently, so the
        summary's ``harm_probability_upper_95`` is a Clopper-Pearson certificate; ``"sobol"``
        covers the ranges evenly but gives no such bound (``None``, said in
        ``harm_probability_bound``).
    screen_modes : int or None
        ``method="fast"``: screen every variant on this many modes first (ignored unless
        below ``n_modes``). A row near a decision (:func:`near_decision`) and every row near
        the extremes (the worst ratio, the lowest and highest closed-loop speeds:
        :func:`_extreme_candidates`) is on ``n_modes``; the largest screening change
        seen on those rows must stay below :data:`SCREEN_CHECK_FRACTION` of the margin, else
        every row is recomputed on ``n_modes`` (``screen_check``).

    Returns
    -------
    HarmResult
        One row per variant (its inputs, open- and closed-loop critical speeds [m/s], the
        ratio, harmed or not); ``summary()`` gives the verdict (``no_harm``, ``harm`` or
        ``unresolved``), the fractions and the harm-probability bound.

    Raises
    ------
    BridgeflapInputError
        Before any work, naming the argument: a count, seed, mode count (also more modes than
        the bridge's model has), design speed, worker count, method, sampling or scheduler
        out of range, a controller file or bridge that cannot be read
        (:class:`~bridgeflap.model.errors.BridgeflapTypeError` for the wrong type).

    Examples
    --------
    >>> from bridgeflap import design
    >>> res = design.do_no_harm("controller.toml", "humber", count=20)  # doctest: +SKIP
    >>> res.summary()["status"]  # doctest: +SKIP
    'no_harm'
    """
    from bridgeflap.design.control.uncertainty import DEFAULT_UNCERTAIN_RANGES
    from bridgeflap.design.io.api_args import check_harm_args

    # every argument before any work: one line naming it (the CLI's bounds)
    controller, spec, grid = check_harm_args(
        controller, bridge, count, seed, n_modes, speed_max_m_s, speeds, ranges, fixed,
        workers, progress, method, screen_modes, sampling, scheduler, HARM_METHODS, SAMPLINGS)
    screen = (screen_modes if method == "fast" and screen_modes is not None
              and screen_modes < n_modes else None)
    name = bridge if isinstance(bridge, str) else spec.name
    if ranges is None:
        ranges = {k: v for k, v in DEFAULT_UNCERTAIN_RANGES.items() if k not in set(fixed)}
    u = np.arange(0.0, 1.5 * speed_max_m_s + 1e-9, 0.5) if grid is None else grid
    samples = _sample(spec, dict(ranges), count, seed, sampling)
    say = progress or (lambda msg: None)
    with _Runner(workers, controller, u, n_modes, speed_max_m_s, method, screen, say,
                 scheduler) as run:  # a scheduler that cannot be reached: before any line
        say(f"do no harm: {count} variants x 2 sweeps ({n_modes} modes"
            f"{f', screened on {screen}' if screen else ''}, 0..{u[-1]:g} m/s, {method})"
            f"{f' on the Dask scheduler {scheduler}' if scheduler else ''}")
        rows = run(samples, range(len(samples)))
        check = {}
        if screen:
            rows, check = _confirm(run, samples, rows, n_modes, speed_max_m_s, say)
    return HarmResult(bridge=str(name), count=count, n_modes=int(n_modes),
                      speed_max_m_s=float(speed_max_m_s), speeds_max_m_s=float(u[-1]),
                      seed=int(seed), ranges=dict(ranges), rows=tuple(rows), method=method,
                      screen_modes=screen, screen_check=check, sampling=sampling)


class _Runner:
    """Rows of chosen samples, serially or in one process pool kept for every pass."""

    def __init__(self, workers, controller, speeds, n_modes, speed_max, method, screen, say,
                 scheduler=None):
        self.args = (controller, speeds, n_modes, speed_max, method, screen)
        self.workers, self.say, self.ex = workers, say, None
        self.scheduler, self.client, self._cluster = scheduler, None, None

    def __enter__(self):
        if self.scheduler is not None:  # a Dask cluster: local, or the scheduler's
            from bridgeflap.design.batch.cluster import cluster_client

            address = None if self.scheduler.strip().lower() == "local" else self.scheduler
            self._cluster = cluster_client(self.workers, address)
            self.client = self._cluster.__enter__()
        elif self.workers > 1:
            from bridgeflap.model.workers import process_pool

            self.ex = process_pool(self.workers)
        return self

    def __exit__(self, *exc):
        if self.ex is not None:
            self.ex.shutdown(cancel_futures=True)
        if self._cluster is not None:
            self._cluster.__exit__(*exc)

    def __call__(self, samples, indices, confirm=None) -> list:
        """Rows of ``samples[indices]``; ``confirm``: per index, ``(loops, earlier row)`` to
        put on all modes (None: the screening decides)."""
        indices = list(indices)
        confirm = dict(zip(indices, confirm, strict=True)) if confirm is not None else {}
        rows: dict = {}
        step = max(1, len(indices) // 10)
        eta = Eta(len(indices))

        def done(i, row):
            rows[i] = row
            if len(rows) % step == 0 or len(rows) == len(indices):
                self.say(f"do no harm: {len(rows)}/{len(indices)} variants "
                         f"{eta.text(len(rows))}")

        if self.client is not None:
            from dask.distributed import as_completed as dask_completed

            futures = {self.client.submit(_rows_of, [samples[i]], *self.args, confirm.get(i),
                                          pure=False): i for i in indices}
            for f in dask_completed(list(futures)):
                done(futures[f], f.result()[0])
        elif self.ex is None:
            for i in indices:
                done(i, _rows_of([samples[i]], *self.args, confirm.get(i))[0])
        else:
            from concurrent.futures import as_completed

            futures = {self.ex.submit(_rows_of, [samples[i]], *self.args, confirm.get(i)): i
                       for i in indices}
            for f in as_completed(futures):
                done(futures[f], f.result()[0])
        return [rows[i] for i in indices]


def _on(row, n_modes, loops=("open_loop", "closed_loop")) -> bool:
    """Whether the row's ``loops`` are on ``n_modes`` (a row without counts: yes)."""
    return all(row.get(f"{k}_modes", n_modes) == n_modes for k in loops)


def _extreme_candidates(rows, n_modes) -> dict:
    """``{row: loops}`` of screened rows that may hold the worst ratio (both loops) or the
    lowest or highest closed-loop speed (the closed loop).

    Within the a-posteriori limit of the screening change (``SCREEN_CHECK_FRACTION x
    SCREEN_MARGIN_REL``, twice that for the ratio) of the extreme: a row outside it stays
    outside on ``n_modes`` as long as the check passes, so the extremes are ``n_modes`` values.
    """
    m = SCREEN_CHECK_FRACTION * SCREEN_MARGIN_REL
    ratios = [r["closed_over_open"] for r in rows
              if r["resolved"] and r["closed_over_open"] is not None]
    speeds = [r["closed_loop_critical_speed_m_s"] for r in rows
              if r["closed_loop_critical_speed_m_s"] is not None]
    r_min = min(ratios, default=None)
    u_min, u_max = min(speeds, default=None), max(speeds, default=None)
    out = {}
    for i, r in enumerate(rows):
        q, cl = r["closed_over_open"], r["closed_loop_critical_speed_m_s"]
        if (not _on(r, n_modes) and r_min is not None and q is not None
                and q <= r_min * (1 + 2 * m)):
            out[i] = ("open_loop", "closed_loop")
        elif (not _on(r, n_modes, ("closed_loop",)) and cl is not None
              and (cl <= u_min * (1 + m) or cl >= u_max * (1 - m))):
            out[i] = ("closed_loop",)
    return out


def _screen_change(rows, n_modes) -> float:
    """The largest relative change of a critical speed from its screening, over the loops
    recomputed on ``n_modes`` (0 when none has both)."""
    worst = 0.0
    for r in rows:
        for k in ("open_loop", "closed_loop"):
            a, b = r.get(f"screen_{k}_critical_speed_m_s"), r[f"{k}_critical_speed_m_s"]
            if r.get(f"{k}_modes") == n_modes and a is not None and b is not None:
                worst = max(worst, abs(b / a - 1.0))
    return worst


def _confirm(run, samples, rows, n_modes, speed_max, say):
    """Rows near the reported extremes on ``n_modes``, then the a-posteriori check."""
    rows = list(rows)

    def redo(todo: dict):
        idx = list(todo)
        for i, new in zip(idx, run(samples, idx, [(todo[i], rows[i]) for i in idx]),
                          strict=True):
            rows[i] = new

    for _ in range(len(rows)):  # each pass recomputes at least one row, or stops
        todo = _extreme_candidates(rows, n_modes)
        if not todo:
            break
        say(f"do no harm: {len(todo)} variants near the extremes on {n_modes} modes")
        redo(todo)
    change = _screen_change(rows, n_modes)
    limit = SCREEN_CHECK_FRACTION * SCREEN_MARGIN_REL
    check = {"margin_rel": SCREEN_MARGIN_REL, "largest_change_rel": change,
             "limit_rel": limit,
             "loops_compared": sum(r.get(f"{k}_modes") == n_modes
                                   and r.get(f"screen_{k}_critical_speed_m_s") is not None
                                   for r in rows for k in ("open_loop", "closed_loop")),
             "passed": change <= limit}
    if not check["passed"]:
        todo = {i: ("open_loop", "closed_loop") for i, r in enumerate(rows)
                if not _on(r, n_modes)}
        say(f"do no harm: screening change {100 * change:.2f} % above {100 * limit:.2f} %: "
            f"{len(todo)} more variants on {n_modes} modes")
        redo(todo)
    return rows, check
