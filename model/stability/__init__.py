"""model.stability."""
