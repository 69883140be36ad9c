"""design.io."""
