"""model.aeroelastic."""
