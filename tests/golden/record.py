"""Record the golden numbers: ``cd tests && python -m golden.record [NAME ...]``."""

from __future__ import annotations

import json
import sys
import tempfile
from pathlib import Path

from golden.cases import CASES, HERE, run_case, strip_volatile


def main(names: list[str]) -> None:
    for name, argv, _ in CASES:
        if names and name not in names:
            continue
        with tempfile.TemporaryDirectory() as tmp:
            data = strip_volatile(run_case(name, argv, Path(tmp)))
        (HERE / f"{name}.json").write_text(json.dumps(data, indent=1, sort_keys=True) + "\n")
        print(f"recorded {name}", file=sys.stderr)


if __name__ == "__main__":
    main(sys.argv[1:])
