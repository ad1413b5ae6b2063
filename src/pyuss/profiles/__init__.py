"""pyuss.profiles."""
