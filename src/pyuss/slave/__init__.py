"""pyuss.slave."""
