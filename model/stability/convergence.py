"""Mode-count convergence of the flutter and divergence speeds: ladder study and truncation error.

The aeroelastic state carries the lowest ``n`` vertical and torsional modes
(:meth:`bridgeflap.model.structure.modes.ModalModel.structural_basis`). :func:`mode_convergence`
solves the same bridge on a ladder of mode counts (default :data:`DEFAULT_MODE_COUNTS`) with one
modal model, and
:func:`truncation_error` compares one count with a larger one (``n + 8`` unless told) so that a
headline number can carry its truncation error. Conventions: see :mod:`bridgeflap.model`.

Convergence criterion (stated, docs/humber_data.md#mode-count-convergence)
------------------------------------------------------------------------
The step change of a count ``n_i`` is ``|U(n_{i+1}) - U(n_i)| / U(n_{i+1})`` [%] and its error
against the reference is ``|U(n_i) - U(n_max)| / U(n_max)`` [%], ``n_max`` the largest count. A
count is **converged** when, for the flutter and the divergence speed alike, its step change and
its error against the reference, *and those of every larger count on the ladder*, are below the
tolerance (:data:`TOLERANCE_PCT`, 0.05 %). (Small steps can add up: one corner of the input
ranges moves 0.044 %, 0.010 % and 0.0002 % in its last three steps, 0.055 % in all.) Stopping
at the first small step is not enough: on the built-in Humber the 8 -> 12 step moves the
flutter speed by 2e-4 % and the 12 -> 16 step by 3.3 %, because the second symmetric
torsional mode TS2 is the 14th vertical/torsional mode. Both numbers are reported
(``converged_modes`` and ``first_small_step_modes``) so that the trap stays visible. The largest
count of the ladder has no step change of its own and is never called converged.

A count whose sweep finds no converged crossing is never converged (with 8 modes on some corners
no torsional mode is retained, and nothing flutters). A mechanism with the same non-converged
status at every count (for example divergence beyond the speed grid, ``no_crossing_in_range``)
does not enter the criterion and is named in ``mechanisms_not_found``; a mechanism found with
fewer modes but not with the most makes the study ``unstable_statuses``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bridgeflap.model.aeroelastic import statespace
from bridgeflap.model.arguments import MAX_MODES, counts, number
from bridgeflap.model.errors import BridgeflapInputError
from bridgeflap.model.results import ResultData
from bridgeflap.model.stability.sweeps import CONVERGED, check_speeds, sweep
from bridgeflap.model.structure.bridge_arg import BridgeArg, takes_bridge
from bridgeflap.model.structure.fe import assemble
from bridgeflap.model.structure.modes import ModalModel, solve
from bridgeflap.model.structure.spec import BridgeSpec

__all__ = ["DEFAULT_MODE_COUNTS", "TOLERANCE_PCT", "TRUNCATION_STEP", "ConvergenceResult",
           "mode_convergence", "truncation_error"]

#: ladder of retained vertical + torsional mode counts of :func:`mode_convergence`
DEFAULT_MODE_COUNTS = (8, 12, 16, 20, 24, 30, 40)
#: a speed has converged in the mode count when it moves less than this [%]
TOLERANCE_PCT = 0.05
#: :func:`truncation_error` compares ``n`` with ``n + TRUNCATION_STEP`` modes by default
TRUNCATION_STEP = 8

_MECHANISMS = ("flutter", "divergence")


def _counts(counts) -> tuple[int, ...]:
    try:
        c = [int(n) for n in counts]
    except (TypeError, ValueError):
        raise BridgeflapInputError("modes", "mode counts must be integers") from None
    if len(c) < 2:
        raise BridgeflapInputError("modes", "a convergence ladder needs at least two counts")
    if c[0] < 1 or any(b <= a for a, b in zip(c[:-1], c[1:], strict=False)):
        raise BridgeflapInputError("modes", f"counts must be positive and increasing, got {c}")
    return tuple(c)


def _available(modal) -> int:
    """Number of vertical and torsional modes the modal model holds (and lateral ones when
    flutter-derivative loads retain them, :mod:`bridgeflap.model.structure.modal_import`)."""
    der = getattr(getattr(modal, "spec", None), "derivatives", None)
    fams = ("vertical", "torsional") + (("lateral",) if der is not None and der.lateral else ())
    return sum(m.family in fams for m in modal.modes)


def _modal(spec: BridgeSpec) -> ModalModel:
    """Statics, assembly and all modes of ``spec`` (as
    :func:`bridgeflap.model.analysis.modal_model`; this module sits below the facade and does not
    import it)."""
    return solve(assemble(spec))


def _solve(spec, modal, n, u, order, rfa, method="dense") -> dict:
    """One stability sweep with ``n`` modes (``method`` of
    :func:`bridgeflap.model.stability.sweeps.sweep`): the
    numbers the ladder needs."""
    if getattr(spec, "derivatives", None) is not None:  # flutter-derivative loads
        from bridgeflap.model.aeroelastic.derivative_system import derivative_bridge_system

        system = derivative_bridge_system(spec, modal, int(n))
    else:
        system = statespace.spec_system(spec, modal.structural_basis(int(n)), order, rfa)
    sw = sweep(system, u, method=method)
    s = sw.summary()
    return {"n_modes": int(n), "states": int(system.n_states),
            "flutter_speed_m_s": s["flutter_speed_m_s"], "flutter_status": s["flutter_status"],
            "flutter_frequency_hz": s["flutter_frequency_hz"],
            "divergence_speed_m_s": s["divergence_speed_m_s"],
            "divergence_status": s["divergence_status"],
            "critical_branch_label": s["critical_branch_label"],
            "labels": tuple(system.basis.labels)}


def _change_pct(a: float, b: float) -> float:
    """``|a - b| / |b|`` [%], NaN unless both are finite."""
    if not (np.isfinite(a) and np.isfinite(b)) or b == 0:
        return float("nan")
    return float(100.0 * abs(a - b) / abs(b))


@dataclass(frozen=True)
class ConvergenceResult(ResultData):
    """Flutter and divergence speeds [m/s] against the number of retained modes.

    Attributes
    ----------
    bridge : str
    rows : tuple of dict
        One row per count: speeds, statuses, ``added_modes`` (labels that entered since the
        previous count), ``flutter_step_change_pct`` / ``divergence_step_change_pct`` (to the
        next count; NaN for the last) and ``*_error_vs_reference_pct`` (to the largest count).
    tolerance_pct : float
        [%].
    converged_modes : int or None
        Smallest count whose own and every later step change and error against the largest
        count are below the tolerance (module docstring).
    first_small_step_modes : int or None
        Smallest count whose own step change is below the tolerance (the naive rule, shown
        because it stops too early).
    mechanisms_not_found : tuple of str
        Mechanisms with the same non-converged status at every count (left out of the rule).
    status : str
        ``"converged"``, ``"not_converged"`` (no count passes) or ``"unstable_statuses"``
        (a mechanism found with fewer modes is not found with the most).
    """

    bridge: str
    rows: tuple
    tolerance_pct: float
    converged_modes: int | None
    first_small_step_modes: int | None
    mechanisms_not_found: tuple
    status: str
    erected_fraction: float = 1.0
    half_chord_m: float = float("nan")

    _HEADLINE_KEYS = ("bridge", "erected_fraction", "tolerance_pct", "converged_modes",
                      "first_small_step_modes", "reference_modes", "status")

    def row(self, n_modes: int) -> dict:
        """The row of ``n_modes``.

        Parameters
        ----------
        n_modes : int
            A mode count of the ladder.

        Returns
        -------
        dict
            Its speeds [m/s], changes [%] and added modes.

        Raises
        ------
        BridgeflapInputError
            ``modes``: ``n_modes`` is not on the ladder.
        """
        for r in self.rows:
            if r["n_modes"] == n_modes:
                return r
        raise BridgeflapInputError("modes", f"{n_modes} is not on the ladder")

    def error_at_pct(self, n_modes: int, mechanism: str = "flutter") -> float:
        """``|U(n) - U(n_max)| / U(n_max)`` [%] against the largest count of the ladder.

        Parameters
        ----------
        n_modes : int
            A mode count of the ladder.
        mechanism : {"flutter", "divergence"}, default "flutter"
            Which speed.

        Returns
        -------
        float
            The relative difference [%] (NaN when either speed was not found).

        Raises
        ------
        BridgeflapInputError
            ``modes``: ``n_modes`` is not on the ladder.
        """
        last = self.rows[-1]
        return _change_pct(self.row(n_modes)[f"{mechanism}_speed_m_s"],
                           last[f"{mechanism}_speed_m_s"])

    def summary(self) -> dict:
        """JSON-ready ``{bridge, tolerance_pct, status, converged_modes, ..., rows}``.

        Returns
        -------
        dict
            The verdict (``status``, ``converged_modes`` at ``tolerance_pct`` [%]) and one dict
            per rung under ``rows``.
        """
        rows = [{k: (list(v) if isinstance(v, tuple) else v) for k, v in r.items()
                 if k != "labels"} for r in self.rows]
        return {"bridge": self.bridge, "erected_fraction": self.erected_fraction,
                "half_chord_m": self.half_chord_m, "tolerance_pct": self.tolerance_pct,
                "status": self.status, "converged_modes": self.converged_modes,
                "first_small_step_modes": self.first_small_step_modes,
                "mechanisms_not_found": list(self.mechanisms_not_found),
                "reference_modes": self.rows[-1]["n_modes"], "rows": rows}

    def table(self) -> str:
        """Plain-text table of the ladder (step: to the next count; error: to the largest).

        Returns
        -------
        str
            One line per mode count: flutter and divergence speeds [m/s], their step and error
            [%] and the modes added.
        """
        lines = [f"{'modes':>5} {'U_F [m/s]':>10} {'step %':>8} {'error %':>8} "
                 f"{'U_D [m/s]':>10} {'step %':>8} {'error %':>8}  added modes"]
        for r in self.rows:
            lines.append(f"{r['n_modes']:5d} {r['flutter_speed_m_s']:10.3f} "
                         f"{r['flutter_step_change_pct']:8.4f} "
                         f"{r['flutter_error_vs_reference_pct']:8.4f} "
                         f"{r['divergence_speed_m_s']:10.3f} "
                         f"{r['divergence_step_change_pct']:8.4f} "
                         f"{r['divergence_error_vs_reference_pct']:8.4f}  "
                         f"{' '.join(r['added_modes'])}")
        return "\n".join(lines)

    def plot(self, ax=None):
        """Relative change [%] of both speeds against the largest count, log scale.

        Parameters
        ----------
        ax : matplotlib.axes.Axes, optional
            Axes to draw on (default: a new figure).

        Returns
        -------
        matplotlib.figure.Figure
            The figure drawn on (a new one when no axes are given).
        """
        if ax is None:
            import matplotlib.pyplot as plt

            _, ax = plt.subplots(figsize=(6, 4), layout="constrained")
        n = [r["n_modes"] for r in self.rows[:-1]]
        for mech, style in (("flutter", "o-"), ("divergence", "s--")):
            e = [max(self.error_at_pct(k, mech), 1e-8) for k in n]
            ax.semilogy(n, e, style, label=mech)
        ax.axhline(self.tolerance_pct, color="k", lw=0.8, ls=":", label="tolerance")
        ax.set_xlabel("retained vertical + torsional modes")
        ax.set_ylabel(f"|U(n) - U({self.rows[-1]['n_modes']})| / U [%]")
        ax.set_title(f"{self.bridge}: mode-count convergence")
        ax.grid(alpha=0.3, which="both")
        ax.legend(fontsize=8)
        return ax


@takes_bridge(counts=counts(1, MAX_MODES), tolerance_pct=number(0.0, 100.0, strict=True))
def mode_convergence(bridge: BridgeArg, speeds, counts=DEFAULT_MODE_COUNTS,
                     tolerance_pct: float = TOLERANCE_PCT, order: str = "modal",
                     rfa: str = "rfa4") -> ConvergenceResult:
    """Flutter and divergence speeds of ``spec`` on a ladder of retained mode counts.

    Parameters
    ----------
    bridge : str, os.PathLike or BridgeSpec
    speeds : array_like
        Wind-speed grid [m/s] of every sweep (crossings refined to 1e-3 m/s).
    counts : sequence of int
        Increasing numbers of retained vertical + torsional modes; counts above what the modal
        model holds are dropped (at least two must remain).
    tolerance_pct : float
        Convergence tolerance [%] (module docstring).
    order, rfa : str
        As :func:`bridgeflap.model.analysis.bridge_system` (``"modal"``/``"full"``;
        ``"rfa4"``/``"jones"``).

    Returns
    -------
    ConvergenceResult
        Flutter and divergence speed per mode count, and the count from which both stay within
        ``tolerance_pct``; ``table()``, ``plot()``.

    Raises
    ------
    BridgeflapInputError
        A bad bridge, speed grid or ladder (fewer than two counts left).
    """
    spec = bridge  # loaded by takes_bridge: a BridgeSpec (or a stage)
    u = check_speeds(speeds)
    counts = _counts(counts)
    if not (np.isfinite(tolerance_pct) and tolerance_pct > 0):
        raise BridgeflapInputError("tolerance_pct", f"must be positive, got {tolerance_pct}")
    modal = _modal(spec)
    counts = _counts([n for n in counts if n <= _available(modal)])
    rows = [_solve(spec, modal, n, u, order, rfa) for n in counts]
    prev: tuple = ()
    for i, r in enumerate(rows):
        r["added_modes"] = tuple(lab for lab in r["labels"] if lab not in prev)
        prev = r["labels"]
        for mech in _MECHANISMS:
            nxt = rows[i + 1][f"{mech}_speed_m_s"] if i + 1 < len(rows) else float("nan")
            r[f"{mech}_step_change_pct"] = _change_pct(r[f"{mech}_speed_m_s"], nxt)
    used, not_found, status = [], [], "converged"
    last = rows[-1]
    for mech in _MECHANISMS:
        st = {r[f"{mech}_status"] for r in rows}
        if last[f"{mech}_status"] == CONVERGED:
            used.append(mech)
        elif len(st) == 1:
            not_found.append(mech)
        else:  # found with fewer modes, lost with the most: nothing can be said
            status = "unstable_statuses"
    for r in rows:
        for mech in _MECHANISMS:
            r[f"{mech}_error_vs_reference_pct"] = _change_pct(r[f"{mech}_speed_m_s"],
                                                             last[f"{mech}_speed_m_s"])
    # NaN (a count without a converged crossing) compares False: never small
    small = [all(r[f"{m}_step_change_pct"] < tolerance_pct
                 and r[f"{m}_error_vs_reference_pct"] < tolerance_pct for m in used)
             for r in rows[:-1]]
    first = next((rows[i]["n_modes"] for i, r in enumerate(rows[:-1])
                  if all(r[f"{m}_step_change_pct"] < tolerance_pct for m in used)), None)
    conv = None
    for i in range(len(small) - 1, -1, -1):
        if not small[i]:
            break
        conv = rows[i]["n_modes"]
    if status == "converged" and (conv is None or not used):
        status = "not_converged"
    if status != "converged":
        conv = None
    return ConvergenceResult(spec.name, tuple(rows), float(tolerance_pct), conv, first,
                             tuple(not_found), status, spec.erected_fraction,
                             spec.deck.half_chord_m)


@takes_bridge
def truncation_error(bridge: BridgeArg, n_modes: int, speeds, reference_modes: int | None = None,
                     order: str = "modal", rfa: str = "rfa4", modal=None,
                     at_n: dict | None = None, sweep_method: str = "dense") -> dict:
    """Truncation-error estimate of the flutter and divergence speeds at ``n_modes`` modes.

    ``|U(n) - U(n_ref)| / U(n_ref)`` [%] with ``n_ref = n_modes + 8`` (:data:`TRUNCATION_STEP`)
    unless ``reference_modes`` is given, capped at the modes the model holds. The estimate is
    only as good as the modes added: if no mode that matters (a symmetric torsional mode on
    Humber) enters between ``n`` and ``n_ref`` it is too small (module docstring), which is why
    the default step spans 8 modes and why :func:`mode_convergence` checks a whole ladder.
    ``sweep_method`` is :func:`bridgeflap.model.stability.sweeps.sweep`'s ``method`` of both sweeps.

    Parameters
    ----------
    bridge : str, path-like or BridgeSpec
        A built-in name, a bridge TOML file or a spec.
    n_modes : int
        The retained vertical + torsional modes whose error is estimated.
    speeds : array_like or str
        Wind speeds [m/s] of both sweeps.
    reference_modes : int, optional
        The reference count (default ``n_modes + 8``, capped at what the model holds).
    order, rfa : str
        As :func:`bridgeflap.model.bridge_system`.
    modal : ModalModel, optional
        Modes already solved for ``bridge``.
    at_n : dict, optional
        The summary of a sweep at ``n_modes`` already run (saves that sweep).
    sweep_method : {"dense", "fast"}, default "dense"
        As :func:`bridgeflap.model.sweep`.

    Returns
    -------
    dict
        ``n_modes``, ``reference_modes``, ``flutter_speed_m_s``,
        ``flutter_reference_speed_m_s``, ``flutter_truncation_error_pct`` and the same three for
        divergence, and ``truncation_status``: ``"converged"`` when both speeds are converged
        at both counts; otherwise the failing mechanism's statuses and NaN for its error
        (a mechanism with no crossing at either count gives NaN and says so).
    """
    spec = bridge  # loaded by takes_bridge: a BridgeSpec (or a stage)
    n = int(n_modes)
    if n < 1:
        raise BridgeflapInputError("modes", f"must be at least 1, got {n_modes}")
    u = check_speeds(speeds)
    modal = _modal(spec) if modal is None else modal
    avail = _available(modal)
    if n > avail:
        raise BridgeflapInputError("modes", f"{n} modes asked, the model holds {avail}")
    ref = n + TRUNCATION_STEP if reference_modes is None else int(reference_modes)
    if ref <= n:
        raise BridgeflapInputError("reference_modes", f"must exceed n_modes ({n}), got {ref}")
    ref = min(ref, avail)
    out = {"n_modes": n, "reference_modes": ref}
    if ref == n:  # every mode is retained already: nothing left to truncate
        a = at_n if at_n is not None else _solve(spec, modal, n, u, order, rfa, sweep_method)
        b = a
    else:
        # ``at_n``: the summary of an n-mode sweep on the same grid already computed by the
        # caller (its flutter/divergence speeds and statuses), so it is not repeated
        a = at_n if at_n is not None else _solve(spec, modal, n, u, order, rfa, sweep_method)
        b = _solve(spec, modal, ref, u, order, rfa, sweep_method)
    bad = []
    for mech in _MECHANISMS:
        ua, ub = a[f"{mech}_speed_m_s"], b[f"{mech}_speed_m_s"]
        ok = a[f"{mech}_status"] == b[f"{mech}_status"] == CONVERGED
        out[f"{mech}_speed_m_s"] = ua
        out[f"{mech}_reference_speed_m_s"] = ub
        out[f"{mech}_truncation_error_pct"] = _change_pct(ua, ub) if ok else float("nan")
        if not ok:
            bad.append(f"{mech}: {a[f'{mech}_status']} at {n}, {b[f'{mech}_status']} at {ref}")
    out["truncation_status"] = CONVERGED if not bad else "; ".join(bad)
    return out
