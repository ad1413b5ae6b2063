"""pyuss.drive."""
