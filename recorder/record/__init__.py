"""Recording LeRobot datasets from a glove: the fixed-rate loop, crash-safe storage, episode control."""
