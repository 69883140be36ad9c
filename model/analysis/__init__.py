"""High-level analyses on a bridge definition: modes, flutter, erection, frequency ratio.

Plain functions of a ``bridge`` (a name, a file or a
:class:`~bridgeflap.model.structure.spec.BridgeSpec`) and grids of wind speeds [m/s] and erected
fractions [-] (``"0:85:0.5"`` text or numbers,
:func:`bridgeflap.model.grid.speed_grid`); the default grids belong to
:mod:`bridgeflap.design.studies.analyses`; the argument names are those of docs/api_vocabulary.md.
Each returns a frozen result object with ``summary()`` (JSON-ready numbers with units in the key
names and statuses) and ``plot()``. Conventions: see :mod:`bridgeflap.model`.

>>> from bridgeflap.model.structure.loader import load_bridge                  # doctest: +SKIP
>>> res = flutter(load_bridge("humber"), np.arange(0.0, 85.5, 0.5))  # doctest: +SKIP
>>> res.summary()["flutter_speed_m_s"]                     # doctest: +SKIP

The facade lives in three modules: ``core`` (modal model, aeroelastic system, flutter),
``stages`` (erection stages and the frequency ratio) and ``closed_loop`` (closed-loop flutter
with a flap controller, exact p-k); every name is imported here.

May import: every room of :mod:`bridgeflap.model` below it.
"""

from __future__ import annotations

import numpy as np  # noqa: F401 - the docstring example's name

from bridgeflap.model.analysis.closed_loop import (  # noqa: F401
    ClosedLoopFlutterResult,
    closed_loop_flutter,
    pk_flutter,
)
from bridgeflap.model.analysis.core import (  # noqa: F401
    DEFAULT_MODES,
    FlutterResult,
    bridge_system,
    check_speeds,
    critical_speed,
    flutter,
    modal_model,
)
from bridgeflap.model.analysis.stages import (  # noqa: F401
    DECK_SHARE_FACTOR,
    ErectionResult,
    FrequencyRatioResult,
    _fractions,
    erection,
    first_symmetric_deck_mode,
    first_symmetric_frequency_hz,
    frequency_ratio,
    fundamental_content,
)
