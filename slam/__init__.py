"""slam package (being built)."""
