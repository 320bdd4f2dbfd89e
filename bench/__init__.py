"""bench package (being built)."""
