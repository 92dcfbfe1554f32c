"""The thesis' 16-segment hand model."""
