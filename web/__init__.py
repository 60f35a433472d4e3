"""web package (filled in by later issues)."""
