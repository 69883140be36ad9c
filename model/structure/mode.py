"""One structural mode: family, symmetry, frequency, damping ratio, shares and its label.

The record of :mod:`bridgeflap.model.structure.modes` (the FE modes) and of
:mod:`bridgeflap.model.structure.modal_model` (the modes of an imported modal model); it imports no
structural model, so both can use it. ``bridgeflap.model.structure.modes.Mode`` is the same class.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["Mode"]


@dataclass(frozen=True)
class Mode:
    """One structural mode."""

    family: str
    symmetry: str
    frequency_hz: float
    damping_ratio: float
    order: int  # 1-based order within (family, symmetry)
    main_span_share: float  # fraction of the mode's nodal norm in the main span
    deck_share: float = 1.0  # kinetic-energy fraction in the deck (lateral: deck vs cables)

    span: str = "main"  # span holding most of the mode ("main" or a side-span name)

    @property
    def label(self) -> str:
        """Short label such as ``TS1`` or ``VA2``; side-span modes: ``V-barton1``."""
        if self.span != "main":
            return f"{self.family[0].upper()}-{self.span}{self.order}"
        return f"{self.family[0].upper()}{self.symmetry[0].upper()}{self.order}"

    def as_dict(self) -> dict:
        """JSON-ready dict (the ``modes`` CLI contract)."""
        return {"label": self.label, "family": self.family, "symmetry": self.symmetry,
                "frequency_hz": self.frequency_hz, "damping_ratio": self.damping_ratio,
                "main_span_share": self.main_span_share, "deck_share": self.deck_share,
                "span": self.span}
