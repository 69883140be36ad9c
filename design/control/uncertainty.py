"""The stated uncertainty set of the estimated bridge inputs: the ranges the design's
robustness variants (:mod:`bridgeflap.design.control.review.checks`), the do-no-harm check
(:mod:`bridgeflap.design.assessment.harm`) and the global sensitivity study
(:mod:`bridgeflap.design.studies.screening`, which also serves it) sample. It sits in the lowest
room that uses it, so every user imports it downwards. A leaf module (no design imports)."""

from __future__ import annotations

#: Ranges [SI] of the estimated Humber inputs (docs/humber_data.md#estimated-inputs
#: and humber.toml sources).
DEFAULT_UNCERTAIN_RANGES = {
    # lumped section of humber.toml, 5.99e5 kg m^2/m, +-15 % (the split of the steel and the
    # surfacing thickness 30-45 mm are estimates)
    "deck.mass_inertia_kgm2_per_m": (5.1e5, 6.9e5),
    # GJ updated to TS1, 5.905e11, +-20 % (the unweighted fit to all three torsional modes,
    # 4.74e11, lies at the lower end; initial Bredt estimate 4.7e11). Centred on the old
    # updated value 4.74e11 before the VS1/TS1 model updating
    "deck.gj_nm2": (4.7e11, 7.1e11),
    # EI updated to VS1, 2.976e12, +20 % and down to the unweighted fit to all six vertical
    # modes (1.97e12); initial estimate ~1e12 (was 1.0e12-2.5e12 about the old 1.98e12)
    "deck.ei_vertical_nm2": (1.95e12, 3.6e12),
    # [DERIVED] plausible sag range 110-125 m
    "cable.main_sag_m": (110.0, 125.0),
    # NOT FOUND; ~22 m [MEMORY, UNVERIFIED]
    "cable.spacing_m": (20.0, 24.0),
    # b = 11 m (22 m box) to 14.25 m (28.5 m overall)
    "deck.half_chord_m": (11.0, 14.25),
    # 6.5-8 [MEMORY, UNVERIFIED], README sensitivity 6-10: enters buffeting only
    "aero.coherence_decay": (6.0, 10.0),
}
