"""Settings dataclasses from a YAML file plus command-line overrides, with one-line errors."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import yaml

from recorder import GloverecError


def load_values(cls, source: Path, required: bool, overrides: dict, what: str) -> dict:
    """The fields for ``cls``: ``source`` (a YAML mapping; missing is fine unless ``required``), then the
    overrides that are not None. Bad YAML, a non-mapping or an unknown key: GloverecError naming the file."""
    values = {}
    if source.is_file():
        try:
            values = yaml.safe_load(source.read_text()) or {}
        except yaml.YAMLError as exc:
            raise GloverecError(f"{source}: not valid YAML ({str(exc).splitlines()[0]})") from None
        if not isinstance(values, dict):
            raise GloverecError(f"{source}: expected a mapping of {what} settings")
    elif required:
        raise GloverecError(f"no such config file: {source}")
    values.update({k: v for k, v in overrides.items() if v is not None})
    unknown = sorted(set(values) - {f.name for f in dataclasses.fields(cls)})
    if unknown:
        raise GloverecError(f"{source}: unknown setting(s) {', '.join(unknown)}")
    return values
