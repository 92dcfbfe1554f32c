"""RecordConfig: what `gloverec record` does, from configs/record/default.yaml and the command line."""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

from recorder import GloverecError
from recorder.settings import load_values

DEFAULTS = Path(__file__).resolve().parents[2] / "configs" / "record" / "default.yaml"
REPO_ID = re.compile(r"^[A-Za-z0-9][A-Za-z0-9._-]*/[A-Za-z0-9][A-Za-z0-9._-]*$")


@dataclass
class RecordConfig:
    glove: str = "emulator"
    robot: str = "glovehand"
    task: str = "pose"
    fps: int = 30
    episodes: int = 10
    episode_time_s: float | None = None
    reset_time_s: float = 2.0
    repo_id: str = "local/glove_demos"
    root: str | None = None
    resume: bool = False
    cameras: list = field(default_factory=list)
    image_size: list = field(default_factory=lambda: [128, 128])
    realtime: bool | None = None  # None: real time for real gloves, fast for the emulator and logs
    retarget: str = "joint"
    seed: int = 0
    glove_rate_hz: float = 200.0
    glove_mode: str = "pose"
    log: bool = True
    task_text: str | None = None

    @classmethod
    def load(cls, path: str | Path | None = None, **overrides) -> RecordConfig:
        """Defaults, then the YAML file (configs/record/default.yaml unless ``path``), then ``overrides``."""
        source = Path(path) if path else DEFAULTS
        values = load_values(cls, source, bool(path), overrides, "record")
        cfg = cls(**values)
        cfg.validate()
        return cfg

    @property
    def is_fast(self) -> bool:
        return (not self.glove.startswith(("serial:", "udp:", "/"))) if self.realtime is None else not self.realtime

    @property
    def root_path(self) -> Path:
        return Path(self.root) if self.root else Path("datasets/recordings") / self.repo_id

    def validate(self) -> None:
        if not REPO_ID.match(self.repo_id or "") or ".." in self.repo_id:
            raise GloverecError(f"bad repo id {self.repo_id!r}: expected USER/NAME (letters, digits, . _ -)")
        for name in ("fps", "episodes"):
            if not isinstance(getattr(self, name), int) or getattr(self, name) <= 0:
                raise GloverecError(f"{name} must be a positive whole number, not {getattr(self, name)!r}")
        if self.episode_time_s is not None and self.episode_time_s <= 0:
            raise GloverecError("episode_time_s must be positive")
        if self.reset_time_s < 0:
            raise GloverecError("reset_time_s must be zero or positive")
        if self.glove_mode not in ("pose", "raw"):
            raise GloverecError(f"glove_mode must be pose or raw, not {self.glove_mode!r}")
        if self.retarget not in ("joint", "ik"):
            raise GloverecError(f"retarget must be joint or ik, not {self.retarget!r}")
