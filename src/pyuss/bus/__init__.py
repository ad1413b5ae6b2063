"""pyuss.bus."""
