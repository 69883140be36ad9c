"""design.sensitivity."""
