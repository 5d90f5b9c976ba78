"""Runs: lifecycle, storage and export (the server's layer above the engine)."""
