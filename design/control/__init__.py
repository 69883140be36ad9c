"""design.control."""
