"""`gloverec review`: a session's episodes in a local web page (watch, plot, keep or discard, trim, relabel),
published as a new dataset through the same function `gloverec edit` uses (publish.py)."""
