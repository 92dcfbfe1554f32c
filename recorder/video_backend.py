"""Which video decoder LeRobot should use for a gloverec dataset."""

import functools


@functools.lru_cache(maxsize=1)
def video_backend() -> str:
    """torchcodec when its FFmpeg shared libraries load, else PyAV.

    lerobot 0.6 picks torchcodec whenever the package is installed and, where it cannot load (torchcodec 0.11
    wants FFmpeg 4-8 with libavdevice, which a bare Debian lacks), logs a 20-line warning on every dataset it
    opens before falling back to PyAV. Every dataset gloverec opens passes this choice, so a gloverec command
    stays quiet and decodes the same frames either way."""
    try:
        import torchcodec.decoders  # noqa: F401
    except Exception:  # noqa: BLE001  (RuntimeError/OSError: FFmpeg shared libraries missing)
        return "pyav"
    return "torchcodec"
