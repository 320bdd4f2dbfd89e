"""metrics package (being built)."""
