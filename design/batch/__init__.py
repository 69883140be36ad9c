"""design.batch."""
