"""Forward simulation, synthetic data and (later) sensitivity and Monte Carlo analyses."""
