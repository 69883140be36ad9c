"""Shared case factories for the tests (one definition of each standard case).

* ``humber`` -- the built-in Humber bridge as shipped (session-scoped; specs are frozen).
* ``coarse_humber`` -- the same on the coarse 47 m mesh the fast tests use (30 main-span
  elements; the mesh study in test_structure.py shows the default 23.5 m mesh within 0.08 %).
* :func:`coarse` -- the coarse mesh for any spec (the factory behind ``coarse_humber``).
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from bridgeflap.model.structure.loader import load_bridge
from bridgeflap.model.structure.spec import BridgeSpec

#: element length of the fast tests' coarse mesh [m]
COARSE_ELEMENT_M = 47.0


def coarse(spec: BridgeSpec, element_length_m: float = COARSE_ELEMENT_M) -> BridgeSpec:
    """``spec`` on a coarser mesh (element length [m])."""
    return spec.replace(**{"mesh.element_length_m": element_length_m})


@pytest.fixture(scope="session")
def humber() -> BridgeSpec:
    """The built-in Humber bridge (complete, as shipped)."""
    return load_bridge("humber")


@pytest.fixture(scope="session")
def coarse_humber() -> BridgeSpec:
    """Humber on the coarse 47 m mesh."""
    return coarse(load_bridge("humber"))


@pytest.fixture(scope="module")
def buffeting_problem():
    """``(settings, spec, model)`` of a small design with the buffeting term's code path:
    6 modes, 5 flaps, two buffeting speeds (the 16-mode design's path, seconds to build)."""
    from bridgeflap.design.control.search.driver import build_model
    from bridgeflap.design.control.settings import load_settings

    s = load_settings(None, n_modes=6, verification_modes=6, flap_count=5,
                      robust_design_speeds_m_s=(30.0, 60.0), n_robust_omega=8,
                      buffeting_speeds_m_s=(10.0, 20.0))
    spec, model = build_model(s)
    return s, spec, model


def subprocess_env(**extra) -> dict:
    """The environment of a test's child Python: this checkout first on ``PYTHONPATH`` (the
    package wherever the child's cwd is), one BLAS thread, plus ``extra``."""
    root = str(Path(__file__).resolve().parents[1])
    return {**os.environ, "OPENBLAS_NUM_THREADS": "1",
            "PYTHONPATH": os.pathsep.join(p for p in (root, os.environ.get("PYTHONPATH")) if p),
            **extra}
