"""Task files of the suite (package data)."""
