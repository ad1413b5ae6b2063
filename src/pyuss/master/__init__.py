"""pyuss.master."""
