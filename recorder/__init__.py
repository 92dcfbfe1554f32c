"""gloverec recorder: glove link, fusion, hand model, retargeting, the recording loop and the local hub.

Data flows one way through the subpackages: ``protocol`` (bytes <-> frames) -> ``link`` (ports, threads,
clocks) -> ``hand`` (the 16-segment hand model) -> ... -> datasets. ``emulator`` stands in for the glove.
"""

__version__ = "0.1.0"


class GloverecError(Exception):
    """An error the CLI reports as one line and a non-zero exit (bad input, missing port, ...)."""
