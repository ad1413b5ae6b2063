"""pyuss.protocol."""
