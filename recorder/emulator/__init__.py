"""The glove emulator: a synthetic hand and 12 synthetic MPU9250s behind a real pseudo-terminal."""
