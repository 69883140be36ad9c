"""design.cli."""
