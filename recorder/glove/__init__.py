"""The glove as every command opens it: a GloveConfig (recorder/glove/config.py: emulator, serial, UDP or an MCAP
log) parsed once, and ``open_glove(config)`` (recorder/glove/glove.py): the link or the in-process emulator behind
it, host fusion, and the HandPoses it measures on the loop's clock (recorder/glove/track.py).

This package's __init__ imports nothing, so that the CLI can read a GloveConfig without loading fusion."""
