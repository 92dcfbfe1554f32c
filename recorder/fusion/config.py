"""The fusion component's configuration: one dataclass holding the defaults; a YAML file (the variants in
configs/fusion/*.yaml, or `gloverec calibrate --config FILE`) overrides them (recorder/config.py)."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Annotated

from recorder import config
from recorder.config import STRICT, ConfigError, NonNegative, Positive
from recorder.fusion.bias import BiasSettings
from recorder.fusion.registry import get_filter, settings_for


@dataclass
class FusionConfig:
    """The fusion component's configuration. ``filter_settings``: fields of the filter's settings dataclass
    (recorder/fusion/<filter>.py), checked against it."""

    __pydantic_config__ = STRICT

    filter: str = "inertial"  # a registered filter (recorder/fusion/registry.py): inertial, complementary, mahony, ...
    filter_settings: dict = field(default_factory=dict)
    rate_hz: Annotated[float, Positive] = 200.0  # nominal sensing rate (calibration recordings given without times)
    max_dt_s: Annotated[float, Positive] = 0.05  # longest gap integrated in one step (as the firmware)
    track_bias: bool = True
    bias: BiasSettings = field(default_factory=BiasSettings)
    heading_rate: Annotated[float, NonNegative] = 2.0  # 1/s: joint-constraint heading feedback into C (0: off)
    heading_bias_rate: Annotated[float, NonNegative] | None = None  # 1/s^2: the same into the bias tracker
    # (None: the filter's, registered with it)
    parent_share: Annotated[float, NonNegative] | None = None  # share of a joint's heading error corrected on
    # the parent's side (None: the filter's; the relative filter composes children from parents: 0)
    min_visibility: Annotated[float, NonNegative] = 0.3  # a joint feeds back only when it sees this much of a
    # heading change
    limits: bool = True  # clamp joint angles to the anatomical limits

    def __post_init__(self):
        try:
            spec = get_filter(self.filter)
        except ValueError as exc:
            raise ConfigError(str(exc)) from None
        if isinstance(self.bias, dict):
            self.bias = BiasSettings(**self.bias)
        if self.parent_share is None:
            self.parent_share = spec.parent_share
        if self.heading_bias_rate is None:
            self.heading_bias_rate = spec.heading_bias_rate
        try:
            settings_for(self.filter, **self.filter_settings)  # unknown settings: an error now, not later
        except ValueError as exc:
            raise ConfigError(f"filter_settings: {exc}") from None

    @classmethod
    def load(cls, path: str | Path | None = None, **overrides) -> FusionConfig:
        """The defaults, then the YAML file ``path`` (if any), then ``overrides``; ConfigError naming the key."""
        return config.load(cls, path, overrides=overrides)
