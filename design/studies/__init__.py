"""Built-in study definitions (TOML), shipped as package data."""
