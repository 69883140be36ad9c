"""The shortened march of a do-no-harm row (``sweep(..., critical_only=True,
stop_after_rel=r)``): it must give the first crossing of the whole-grid sweep, to the bit, on
bridges whose first crossing is flutter and on ones whose first crossing is divergence, open
and closed loop, and end ``r`` past the first unstable speed.

The fresh-variant check (:mod:`bridgeflap.design.assessment.harm_fast`) leans on this: its
rows read the first crossing alone and whether another lies within ``SCREEN_MARGIN_REL`` above
it.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from bridgeflap.model.errors import BridgeflapInputError
from bridgeflap.model.stability.sweeps import sweep

SPEEDS = np.arange(0.0, 127.5 + 1e-9, 0.5)
STOP = 0.03


def _first(summary):
    """(first crossing speed, mechanism) of a summary."""
    f = summary["flutter_speed_m_s"] if summary["flutter_status"] == "converged" else math.inf
    d = (summary["divergence_speed_m_s"] if summary["divergence_status"] == "converged"
         else math.inf)
    return (f, "flutter") if f <= d else (d, "divergence")


def _systems():
    """Humber on 16 modes at three GJ factors (the open loop's first crossing is flutter at
    0.8 and 1.0 GJ, divergence at 1.2: the torsional frequency rises above the flutter
    coupling), open loop and with the default design's compensator on two pairs of strips."""
    from bridgeflap.model.aeroelastic.control import Compensator
    from bridgeflap.model.aeroelastic.flaps import closed_loop_model
    from bridgeflap.model.structure.loader import load_bridge

    spec0 = load_bridge("humber")
    k = Compensator(-0.7262, -0.3437, -3.7120, 0.2726, 0.3133)
    out = []
    for f in (0.8, 1.0, 1.2):
        spec = spec0.replace(**{"deck.gj_nm2": f * spec0.deck.gj_nm2})
        m = closed_loop_model(spec, (-507.6, -451.2, 451.2, 507.6), 56.4, 16, 3.0, True, True)
        out += [(f"GJ x{f} open", m.open_loop), (f"GJ x{f} closed", m.system(k))]
    return out


@pytest.mark.parametrize("name,system", _systems(), ids=lambda v: v if isinstance(v, str) else "")
def test_shortened_march_gives_the_first_crossing(name, system):
    full = sweep(system, SPEEDS, method="fast", critical_only=True)
    short = sweep(system, SPEEDS, method="fast", critical_only=True, stop_after_rel=STOP)
    u_full, mech_full = _first(full.summary())
    u_short, mech_short = _first(short.summary())
    assert math.isfinite(u_full), name  # every case crosses on the grid
    # the same mechanism, and the speed to the sweep's crossing tolerance (speed_tol, 1e-3
    # m/s: a crossing Newton misses is refined by Brent to it; Newton's own agree to ~1e-6)
    assert mech_short == mech_full, name
    assert u_short == pytest.approx(u_full, abs=1e-3), name
    # it did stop early: the march ends within one coarse step past (1 + STOP) x the first
    # unstable march speed, which lies at most one step above the crossing
    h_max = (SPEEDS[-1] - SPEEDS[0]) / 10
    assert short.speeds[-1] <= (u_full + h_max) * (1 + STOP) + h_max, name
    assert short.speeds[-1] < full.speeds[-1], name


def test_mechanisms_covered():
    """The set above holds both first mechanisms (else the test says less than it claims)."""
    mechs = {_first(sweep(s, SPEEDS, method="fast", critical_only=True).summary())[1]
             for _, s in _systems()[::2]}
    assert mechs == {"flutter", "divergence"}


@pytest.mark.parametrize("bad", [0.0, -0.1, 11.0, float("nan"), "0.1"])
def test_stop_after_rel_checked(bad):
    _, system = _systems()[0]
    with pytest.raises(BridgeflapInputError, match="stop_after_rel"):
        sweep(system, SPEEDS, method="fast", critical_only=True, stop_after_rel=bad)


def test_row_margin_covers_the_static_condition():
    """A row's static path needs to know whether a flutter crossing lies within
    SCREEN_MARGIN_REL above the divergence: the march must reach past that."""
    from bridgeflap.design.assessment.harm_fast import STOP_AFTER_REL
    from bridgeflap.design.assessment.harm_verdict import SCREEN_MARGIN_REL

    assert STOP_AFTER_REL >= 2 * SCREEN_MARGIN_REL
