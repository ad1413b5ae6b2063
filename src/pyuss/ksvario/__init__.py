"""pyuss.ksvario."""
