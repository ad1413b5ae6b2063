"""PROFIBUS-DP slave for the simulated KS VARIO: FDL codec, DP slave state machine, line I/O."""
