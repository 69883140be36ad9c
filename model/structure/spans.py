"""Span geometry along the deck: where each span starts and ends, where the towers stand.

Distances in metres from the north anchorage, spans north to south (see :mod:`bridgeflap.model`).
Used by the mode-shape figures (:mod:`bridgeflap.model.structure.plots`) and the flutter mode shape
(:mod:`bridgeflap.model.stability.modeshape`, which re-exports both names).

May import: the foundation and bridgeflap.model.structure only (the bridge definition, for types).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from bridgeflap.model.structure.spec import BridgeSpec

__all__ = ["span_extents_m", "tower_positions_m"]


def tower_positions_m(spec: BridgeSpec) -> tuple[float, ...]:
    """Distance from the north anchorage [m] of every span boundary between two spans."""
    ends = np.cumsum([s.length_m for s in spec.spans])[:-1]
    return tuple(float(x) for x in ends)


def span_extents_m(spec: BridgeSpec) -> tuple[tuple[str, float, float], ...]:
    """``(name, start, end)`` [m from the north anchorage] of every span."""
    ends = np.concatenate([[0.0], np.cumsum([s.length_m for s in spec.spans])])
    return tuple((s.name, float(a), float(b))
                 for s, a, b in zip(spec.spans, ends[:-1], ends[1:], strict=True))
