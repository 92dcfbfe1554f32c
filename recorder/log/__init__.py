"""Session logs in MCAP (docs/logs.md): ``McapLogger`` writes them as a GloveSource tap, ``McapSource`` plays
them back as a glove, ``read_log`` and ``iter_frames`` read them offline."""

from recorder.log.playback import LogInfo, McapSource, iter_chunks, iter_frames, read_log
from recorder.log.writer import McapLogger

__all__ = ["LogInfo", "McapLogger", "McapSource", "iter_chunks", "iter_frames", "read_log"]
