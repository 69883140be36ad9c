"""``python -m bridgeflap``: the ``bridgeflap`` command line."""

from bridgeflap.design.cli.main import main

if __name__ == "__main__":
    raise SystemExit(main())
