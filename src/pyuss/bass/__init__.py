"""pyuss.bass."""
