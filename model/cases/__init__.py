"""model.cases."""
