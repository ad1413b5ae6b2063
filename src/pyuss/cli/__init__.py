"""pyuss.cli."""
