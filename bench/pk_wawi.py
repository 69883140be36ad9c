"""Former wawi bench, absorbed into :mod:`bench.pk` (same wawi call, plus the fast and reference
p-k and the RFA path): ``python bench/pk_wawi.py [ARGS]`` runs ``python -m bench.pk [ARGS]``."""

from __future__ import annotations

import sys
from pathlib import Path

if __name__ == "__main__":
    sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
    from bench.pk import main

    sys.exit(main())
