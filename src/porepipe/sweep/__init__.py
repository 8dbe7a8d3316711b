"""Resolution and sample-size sweeps, extrapolation to a → 0, adaptive refinement (thesis §4.6.1, §6.2, §7.2, §7.5)."""
