"""Forward simulation of a drop (one trajectory or a batch of dispersed ones) and synthetic sensor data."""
