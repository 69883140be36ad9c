"""model.aero."""
