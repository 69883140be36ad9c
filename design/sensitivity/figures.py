"""Figures of the global sensitivity study: the Morris plane (``sigma`` against ``mu*``).

:meth:`bridgeflap.design.studies.screening.GlobalSensitivityResult.plot` calls it (matplotlib is
imported by the caller; this module only draws on the axis it is given). Speeds in m/s.
"""

from __future__ import annotations

import numpy as np

__all__ = ["morris_mu_sigma"]


def morris_mu_sigma(ax, indices: dict, outputs=("flutter_speed_m_s", "divergence_speed_m_s")):
    """Morris ``sigma`` against ``mu*`` [m/s] per input and output, the line ``sigma = mu*``
    (above it: nonlinear or interacting inputs), each point named."""
    cols = {"flutter_speed_m_s": "C3", "divergence_speed_m_s": "C0"}
    top, missing = 0.0, []
    for out in outputs:
        idx = indices.get(out, {})
        if isinstance(idx.get("status"), str) and idx["status"] != "ok":
            missing.append(f"{out}: {idx['status']}")
        pts = [(n, v["mu_star"], v["sigma"]) for n, v in idx.items() if isinstance(v, dict)]
        if not pts:
            continue
        ms = np.array([p[1] for p in pts])
        sg = np.array([p[2] for p in pts])
        ax.scatter(ms, sg, color=cols.get(out, "C2"), s=30, label=out.replace("_speed_m_s", ""))
        for n, x, y in pts:
            ax.annotate(n.split(".")[-1], (x, y), fontsize=7, xytext=(3, 3),
                        textcoords="offset points")
        top = max(top, float(np.nanmax(np.concatenate([ms, sg]))))
    top = 1.1 * top or 1.0
    if missing:  # say why a point is absent instead of showing an empty plane
        ax.text(0.98, 0.02, "\n".join(missing), transform=ax.transAxes, ha="right",
                va="bottom", fontsize=7, color="r", wrap=True)
    ax.plot([0, top], [0, top], "k:", lw=0.8, label="σ = μ*")
    ax.set_xlim(0, top)
    ax.set_ylim(0, top)
    ax.set_xlabel("μ* (mean absolute elementary effect) [m/s]")
    ax.set_ylabel("σ (spread of the elementary effects) [m/s]")
    ax.set_title("Morris screening: above the line, nonlinear / interacting", fontsize=9)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="upper left")
    return ax
