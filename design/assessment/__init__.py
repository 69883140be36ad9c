"""design.assessment."""
