"""The glove as every command opens it: a GloveConfig (recorder/glove/config.py: a registered glove source, the
emulator, serial, UDP, an MCAP log or a plugin's) parsed once, and ``open_glove(config)`` (recorder/glove/glove.py):
the source's link, host fusion, and the HandPoses it measures on the loop's clock (recorder/glove/track.py).

This package's __init__ imports nothing, so that the CLI can read a GloveConfig without loading fusion."""
