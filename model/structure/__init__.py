"""model.structure."""
