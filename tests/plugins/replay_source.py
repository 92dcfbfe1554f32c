"""A glove source from outside the package (docs/recording.md, "Adding a glove source"): ``replay:FILE`` plays a
session log back, always as fast as it decodes (the built-in ``mcap:`` paces it unless --fast)."""

from pathlib import Path

from recorder.config import ConfigError
from recorder.glove.config import register_glove_source


def _exists(address: str) -> None:
    if not Path(address).is_file():
        raise ConfigError(f"replay:{address}: no such log")


@register_glove_source("replay", device=False, spec="replay:FILE", check=_exists)
def replay(config, realtime: bool = True, **options):
    from recorder.log.playback import McapSource

    return McapSource(config.address, realtime=False, **options)
