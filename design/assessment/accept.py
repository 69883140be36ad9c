"""A design you can install: the compensator design with its acceptance checks folded into its
status (:func:`design`), and the checks of any controller (:func:`accept`).

:func:`design` runs :func:`bridgeflap.design.control.search.driver.design` and then, when it
produced a controller, the acceptance checks of :mod:`bridgeflap.design.assessment.acceptance` on
that controller as written to its file and read back. The verdict is part of the design's status:

==================  =========================================================================
``converged``       the design met every check of the design model and the acceptance checks
                    passed (or were not asked for: ``checks="none"``, said in ``acceptance``)
``harm``            the controller lowers some fresh variant's critical speed below its
                    open-loop one (``DesignResult.controller`` is then None: never handed on)
``failed_checks``   the independent closed loop disagrees with the design's own, or the
                    controller's usable speed (its real actuators in the design turbulence,
                    :mod:`bridgeflap.design.assessment.usable_speed`) is not above the open-loop
                    critical speed (the acceptance block's ``reason`` says which)
``unresolved``      no variant harmed, but some crossing could not be verified
==================  =========================================================================

and any status of the design itself (``unverified``, ``infeasible``, ``failed``) is kept as
it is. The acceptance block is ``DesignResult.extras["acceptance"]`` (in ``summary()`` under
``acceptance``), and the check results (tables) ``extras["acceptance_results"]``.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field, replace
from pathlib import Path

from bridgeflap.design.assessment.harm import MAX_VARIANTS
from bridgeflap.model.errors import BridgeflapTypeError
from bridgeflap.model.results import ResultData
from bridgeflap.model.vocabulary import renamed

__all__ = ["ACCEPTANCE_STATUS", "AcceptanceResult", "accept", "design"]

#: most fresh variants of one validation (the do-no-harm check's own bound)
MAX_SAMPLES = MAX_VARIANTS
#: the design's status for an acceptance verdict (``passed`` and ``not_run`` keep it)
ACCEPTANCE_STATUS = {"harm": "harm", "failed": "failed_checks", "unresolved": "unresolved"}


@dataclass(frozen=True)
class AcceptanceResult(ResultData):
    """The acceptance checks of one controller (:func:`accept`).

    Attributes
    ----------
    status : str
        ``passed``, ``harm``, ``failed``, ``unresolved`` or ``not_run``.
    block : dict
        Strict-JSON block: one entry per check (:mod:`bridgeflap.design.assessment.acceptance`).
    results : dict
        The check result objects by name (tables: ``to_dataframe``).
    """

    status: str
    block: dict
    results: dict = field(default_factory=dict, repr=False, compare=False)

    def summary(self) -> dict:
        """The strict-JSON block (``status`` first).

        Returns
        -------
        dict
            ``status`` (``passed``, ``harm``, ``failed``, ``unresolved`` or ``not_run``), then
            each check's block (its status and numbers, units in the key names).
        """
        return {"status": self.status, **{k: v for k, v in self.block.items()
                                          if k != "status"}}

    _HEADLINE_KEYS = ("status", "checks")

    def table(self, fmt: str = "simple") -> str:
        """One line per check.

        Parameters
        ----------
        fmt : str, default "simple"
            Taken for the results' common ``table(fmt)`` call; the text is always one line per
            check.

        Returns
        -------
        str
            Each check's name, status and headline numbers.
        """
        from bridgeflap.design.assessment.acceptance import acceptance_text

        return acceptance_text(self.block)

    def plot(self, ax=None):
        """The do-no-harm histogram of the fresh variants (closed over open critical speed;
        :meth:`bridgeflap.design.assessment.harm.HarmResult.plot`), or an empty figure when the
        robustness check did not run.

        Parameters
        ----------
        ax : matplotlib.axes.Axes, optional
            Axes to draw on (default: a new figure).

        Returns
        -------
        matplotlib.figure.Figure
            The figure drawn on (a new one when no axes are given).
        """
        from bridgeflap.model.results import figure_of

        rob = self.results.get("robustness")
        if rob is not None:
            return figure_of(rob.plot(ax))
        import matplotlib.pyplot as plt

        fig = ax.figure if ax is not None else plt.figure()
        (ax or fig.add_subplot()).text(0.5, 0.5, f"acceptance {self.status}: no robustness "
                                                 "check", ha="center")
        return fig


def _options(checks, samples, workers, quick, seed, fields=("samples", "workers", "quick")):
    """The checks' sizes, each argument checked before any work (``fields``: the caller's
    names of ``samples``, ``workers`` and ``quick``)."""
    from bridgeflap.design.assessment.acceptance import AcceptanceOptions, parse_checks
    from bridgeflap.design.io.api_args import check_accept_args
    from bridgeflap.model.arguments import MAX_WORKERS, check_int

    if not isinstance(checks, str | list | tuple):
        raise BridgeflapTypeError("checks", "must be all, none or a list of check names, got "
                                            f"{type(checks).__name__}")
    names = parse_checks(checks) if isinstance(checks, str) else parse_checks(
        ",".join(str(c) for c in checks) or "none")
    for name, v, top in ((fields[0], samples, MAX_SAMPLES), (fields[1], workers, MAX_WORKERS)):
        if v is not None:
            check_int(v, name, 1, top)
    check_accept_args(seed, quick, fields[2])
    w = 1 if workers is None else workers
    if quick:
        return AcceptanceOptions.for_quick(names, w, samples)
    base = AcceptanceOptions()
    return replace(base, checks=names, workers=w,
                   samples=base.samples if samples is None else samples,
                   seed=base.seed if seed is None else int(seed))


def accept(controller, settings=None, *, checks="all", samples: int | None = None,
           workers: int | None = None, quick: bool = False, seed: int | None = None,
           closed_loop=None, progress=None, bridge=None,
           closed_loop_limits=None) -> AcceptanceResult:
    """The acceptance checks of ``controller`` (module
    :mod:`bridgeflap.design.assessment.acceptance`).

    Parameters
    ----------
    controller : bridgeflap.model.aeroelastic.control.Controller or path
        The controller (a path: its controller TOML file).
    settings : DesignSettings or path, optional
        The design card it answers to (bridge, speeds, modes, actuator limits; default: the
        default card).
    checks : str or sequence of str
        ``"all"``, ``"none"`` or names of :data:`bridgeflap.design.assessment.acceptance.CHECKS`.
    samples : int, optional
        Fresh variants of the robustness check (default 1000; 8 with ``quick``).
    workers : int, optional
        Processes of the checks (default 1).
    quick : bool
        The CI sizes (8 variants, one short actuator record per speed).
    seed : int, optional
        Seed of the fresh variants (default 11: independent of the design's scenarios).
    closed_loop : bridgeflap.model.aeroelastic.statespace system, optional
        The design's own closed loop for the independent check (default: built from
        ``settings`` and ``controller`` by the design's own model path).
    progress : callable, optional
        ``str -> None``, one line per step.
    bridge : BridgeSpec, name or path, optional
        The bridge the controller was designed for (default ``settings.bridge``): the fresh
        variants are drawn about it.
    closed_loop_limits : dict, optional
        The design's closed- and open-loop limits on its verification model
        (:func:`bridgeflap.design.control.review.checks.closed_loop_limits`), read by the
        usable-speed check (default: computed).

    Returns
    -------
    AcceptanceResult
        ``status`` (``"passed"``, ``"harm"``, ``"failed"``, ``"unresolved"``, ``"not_run"``),
        each check's block and table, ``summary()``, ``table()``, ``plot()``.

    Raises
    ------
    BridgeflapInputError
        A bad controller, card, check name, ``samples`` or ``workers``.
    """
    from bridgeflap.design.assessment.acceptance import acceptance
    from bridgeflap.design.control.settings import DesignSettings, load_settings
    from bridgeflap.design.io.scratch import scratch_folder
    from bridgeflap.model.aeroelastic.controller_file import (
        as_controller,
        load_controller,
        save_controller,
    )

    controller = as_controller(controller, "controller")  # a controller file's path is read
    if settings is None or isinstance(settings, str | Path):
        settings = load_settings("default" if settings is None else settings)
    if not isinstance(settings, DesignSettings):
        raise BridgeflapTypeError("settings", "must be DesignSettings or a card path, got "
                                              f"{type(settings).__name__}")
    if progress is not None and not callable(progress):
        raise BridgeflapTypeError("progress", "must be callable (str -> None), got "
                                              f"{type(progress).__name__}")
    opts = _options(checks, samples, workers, quick, seed)
    if not opts.checks:
        return AcceptanceResult("not_run", {"checks": [], "status": "not_run"})
    _warn_other_bridge(controller, settings, bridge)  # the bridge is read: a bad one stops here
    if closed_loop is None and "independent_check" in opts.checks:
        from bridgeflap.design.control.formulation.problem_model import build_model

        _, model = build_model(settings, n_modes=settings.verification_modes,
                               positions=controller.flap_strip_positions_m, spec=bridge)
        closed_loop = model.system(controller.compensator)
    # the checks read the controller as a user reads it back from its file; the scratch
    # folder lives only for that read (a process killed during the checks leaves none), and
    # one left by a process killed in that instant is removed by the next run
    with scratch_folder("accept") as tmp:
        path = tmp / "controller.toml"
        save_controller(controller, path)
        read_back = load_controller(path)
    block, results = acceptance(read_back, settings, opts, closed_loop=closed_loop,
                                progress=progress, bridge=bridge,
                                closed_loop_limits=closed_loop_limits)
    return AcceptanceResult(block["status"], block, results)


def _warn_other_bridge(controller, settings, bridge) -> None:
    """Warn (:class:`~bridgeflap.model.errors.BridgeflapWarning`) when ``controller`` records
    another bridge than the one it is judged on, as the command line does
    (:func:`bridgeflap.model.aeroelastic.controller_file.check_controller_plant`); flaps that do
    not fit on the bridge are refused naming the field."""
    import warnings

    from bridgeflap.model.aeroelastic.controller_file import check_controller_plant
    from bridgeflap.model.errors import BridgeflapWarning
    from bridgeflap.model.structure.bridge_arg import as_bridge
    from bridgeflap.model.structure.spec import BridgeSpec

    target = settings.bridge if bridge is None else bridge
    spec = as_bridge(target, "bridge")
    if not isinstance(spec, BridgeSpec):
        raise BridgeflapTypeError("bridge", "must be a built-in bridge name, a bridge .toml "
                                            "path or a BridgeSpec, got an aeroelastic system")
    if isinstance(target, BridgeSpec):  # no file to hash: the recorded name is compared
        rec = controller.plant
        note = (None if rec is None or rec.bridge_name == spec.name else
                f"designed on bridge {rec.bridge} ({rec.bridge_name!r}), checked on "
                f"{spec.name!r}: bridge_name differs")
    else:
        note = check_controller_plant(controller, os.fspath(target), spec)
    if note and controller.plant is not None:  # an old file without a record: as before
        warnings.warn(f"controller: {note}", BridgeflapWarning, stacklevel=3)


@renamed
def design(settings, progress=None, bridge=None, warm_start=None, progress_bar=None,
           records=None, *, checks="all", check_samples: int | None = None,
           check_workers: int | None = None, quick_checks: bool = False):
    """Design the compensator and judge it: :func:`bridgeflap.design.control.search.driver.design`,
    then :func:`accept` on its controller, the verdict folded into the status (module docstring).

    Parameters
    ----------
    settings : DesignSettings
        The design card (:func:`bridgeflap.design.control.settings.load_settings`).
    progress, bridge, warm_start, progress_bar, records
        As :func:`bridgeflap.design.control.search.driver.design`.
    checks : str or sequence of str
        Acceptance checks (``"all"``, the default; ``"none"`` skips them and says so).
    check_samples, check_workers : int, optional
        Fresh variants (default 1000) and processes (default 1) of the checks.
    quick_checks : bool
        The CI sizes of the checks.

    Returns
    -------
    bridgeflap.design.control.results.result.DesignResult
        ``controller`` is None unless the status is ``converged``.
    """
    from bridgeflap.design.control.search.driver import design as run_design
    from bridgeflap.design.io.api_args import check_design_args

    check_design_args(settings, progress, bridge, warm_start, progress_bar, records)
    opts = _options(checks, check_samples, check_workers, quick_checks, None,  # before work
                    ("check_samples", "check_workers", "quick_checks"))
    res = run_design(settings, progress=progress, bridge=bridge, warm_start=warm_start,
                     progress_bar=progress_bar, records=records)
    if res.controller is None:
        return res
    if not opts.checks:
        return replace(res, extras={**res.extras, "acceptance": {"checks": [],
                                                                 "status": "not_run"}})
    from bridgeflap.design.assessment.acceptance import design_closed_loop

    acc = accept(res.controller, settings, checks=opts.checks, samples=opts.samples,
                 workers=opts.workers, quick=quick_checks, seed=opts.seed,
                 closed_loop=design_closed_loop(res, settings),
                 progress=progress, bridge=bridge,
                 closed_loop_limits=res.extras.get("closed_loop_limits"))
    extras = {**res.extras, "acceptance": acc.block, "acceptance_results": acc.results}
    if "usable_speed" in acc.results:   # the paper's Fig. 5 (right) as numbers
        extras["response_by_speed"] = acc.results["usable_speed"].response
    status = ACCEPTANCE_STATUS.get(acc.status)
    if status is None:
        return replace(res, extras=extras)
    return replace(res, status=status, controller=None, extras=extras)
