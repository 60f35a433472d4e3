"""controllers package (filled in by later issues)."""
