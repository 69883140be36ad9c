"""model.response."""
