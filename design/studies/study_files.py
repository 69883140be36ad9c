"""What one analysis of a study writes into its folder (:func:`write_outcome`): its result
JSON, its arrays (``.npz``, and ``.nc`` for labelled results), its figures and a designed
controller. Called by :func:`bridgeflap.design.studies.study.run_study` inside the study's
temporary folder, so every file is atomic and the folder is complete before it is moved.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

from bridgeflap.design.io.files import (
    atomic_save_netcdf,
    atomic_savez,
    atomic_write,
    atomic_write_json,
)
from bridgeflap.design.studies.analyses import Outcome

__all__ = ["write_outcome"]


def _labelled(result) -> bool:
    """The result has labelled arrays of its own (a sweep's ``to_xarray``), not only the
    generic table-as-dataset every result has."""
    from bridgeflap.model.results import ResultData

    method = getattr(type(result), "to_xarray", None)
    return callable(method) and method is not ResultData.to_xarray


def write_outcome(kind: str, outcome: Outcome, folder: Path) -> tuple[dict, list[str]]:
    """Write the results, arrays, figures (and a designed controller) of one analysis."""
    summary = dict(outcome.summary)
    controller = getattr(outcome.result, "controller", None) if kind == "design" else None
    if controller is not None:
        from bridgeflap.model.aeroelastic.controller_file import save_controller

        save_controller(controller, folder / "results" / "controller.toml")
        summary["controller_file"] = "results/controller.toml"
    atomic_write_json(folder / "results" / f"{kind}.json", summary)
    if outcome.arrays:
        atomic_savez(folder / "results" / f"{kind}.npz", **outcome.arrays)
    if _labelled(outcome.result):  # sweeps as labelled arrays
        atomic_save_netcdf(folder / "results" / f"{kind}.nc", outcome.result.to_xarray())
    return summary, _save_figures(outcome.figures, folder / "figures")


def _save_figures(figs: Mapping, folder: Path) -> list[str]:
    import matplotlib.pyplot as plt

    names = []
    for name, fig in figs.items():
        atomic_write(folder / f"{name}.png",
                     lambda fh, fig=fig: fig.savefig(fh, format="png", dpi=110,
                                                     bbox_inches="tight"))
        plt.close(fig)
        names.append(f"figures/{name}.png")
    return names
