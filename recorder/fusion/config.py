"""The fusion component's configuration: one dataclass, loaded from configs/fusion/*.yaml, overridable."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from pathlib import Path

from recorder.fusion.bias import BiasSettings
from recorder.fusion.registry import FILTERS, settings_for

PARENT_SHARE = {"complementary": 0.0, "mahony": 0.5, "relative": 0.0, "madgwick": 0.5}
# Madgwick's normalised gradient step does not pull a tilt back in proportion to its error, so a bias learned
# wrongly from the joints lingers: it learns from them more slowly (a 4-minute run ran away at 0.5).
HEADING_BIAS_RATE = {"complementary": 1.0, "mahony": 1.0, "relative": 1.0, "madgwick": 0.2}


@dataclass
class FusionConfig:
    """The fusion component's configuration (configs/fusion/*.yaml)."""

    filter: str = "mahony"
    filter_settings: dict = field(default_factory=dict)
    rate_hz: float = 200.0  # nominal sensing rate (calibration recordings given without times)
    max_dt_s: float = 0.05  # longest gap integrated in one step (as the firmware)
    track_bias: bool = True
    bias: BiasSettings = field(default_factory=BiasSettings)
    heading_rate: float = 2.0  # 1/s: joint-constraint heading feedback into C (0 disables)
    heading_bias_rate: float | None = None  # 1/s^2: the same into the bias tracker (None: per filter)
    parent_share: float | None = None  # share of a joint's heading error corrected on the parent's side
    # (None: PARENT_SHARE[filter]; the relative filter composes children from parents, so 0 there)
    min_visibility: float = 0.3  # a joint feeds back only when it sees this much of a heading change
    limits: bool = True  # clamp joint angles to the anatomical limits
    engine: str = "auto"  # "numba" | "numpy" | "auto"

    def __post_init__(self):
        if self.filter not in FILTERS:
            raise ValueError(f"unknown filter {self.filter!r}; valid filters: {', '.join(FILTERS)}")
        if isinstance(self.bias, dict):
            self.bias = BiasSettings(**self.bias)
        if self.parent_share is None:
            self.parent_share = PARENT_SHARE[self.filter]
        if self.heading_bias_rate is None:
            self.heading_bias_rate = HEADING_BIAS_RATE[self.filter]
        settings_for(self.filter, **self.filter_settings)  # unknown settings: ValueError now, not later
        if self.engine not in ("auto", "numba", "numpy"):
            raise ValueError(f"engine must be auto, numba or numpy, got {self.engine!r}")

    @classmethod
    def load(cls, path, **overrides) -> FusionConfig:
        """From a YAML file (keys as the fields), with keyword overrides (e.g. from the command line)."""
        import yaml

        data = yaml.safe_load(Path(path).read_text()) or {}
        data.update(overrides)
        known = {f.name for f in dataclasses.fields(cls)}
        unknown = sorted(set(data) - known)
        if unknown:
            raise ValueError(f"unknown fusion config key(s) {', '.join(unknown)} in {path}")
        return cls(**data)
