"""TrainConfig: the settings of `gloverec train`. Defaults here; `--config FILE` (e.g. configs/train/quick.yaml)
and the command-line flags override them (recorder/config.py). ``policy`` holds fields of the policy's LeRobot
config (for bc, policies/bc/configuration_bc.py BCConfig), checked against it when training starts."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Literal

from annotated_types import Lt

from recorder import config
from recorder.config import STRICT, NonNegative, Positive, setting


@dataclass
class TrainConfig:
    __pydantic_config__ = STRICT

    steps: Annotated[int, Positive] = setting(3000, "training steps")
    batch_size: Annotated[int, Positive] = setting(256, "frames per batch")
    lr: Annotated[float, Positive] | None = setting(None, "peak learning rate (default: the policy's preset)")
    seed: int = setting(0, "initialisation, split and batch order")
    val_fraction: Annotated[float, NonNegative, Lt(1)] = setting(
        0.1, "share of episodes held out for validation (whole episodes)"
    )
    successful_only: bool = setting(
        True,
        "train on failed demonstrations too (default: only those the recorder marked successful)",
        flag="--all-episodes",
        sets=False,
    )
    intervention_weight: Annotated[float, NonNegative] = setting(
        1.0, "takeover recordings: draw the frames the wearer drove this many times as often as a demonstration's"
    )
    policy_frames: bool = setting(
        False,
        "takeover recordings: train on the frames the policy drove too (default: only the wearer's, as HG-DAgger)",
        flag="--policy-frames",
    )
    learn_from: Literal["executed", "intended"] = setting(
        "executed",
        "the action chunks learnt: the executed action, or the wearer's intended one (expert.action): a DART "
        "recording's before the injected noise (`gloverec record --dart`), a takeover recording's where the policy "
        "drove too (DAgger: every frame counts)",
    )
    val_every: Annotated[int, Positive] | None = setting(None, "validation every N steps (default: steps / 20)")
    save_every: Annotated[int, Positive] | None = setting(1000, "a checkpoint every N steps, and at the end")
    inputs: str | None = setting(
        None,
        "what the policy reads, comma-separated: state, environment (the simulator's object, goal, ...), images "
        "(or images.CAMERA), task (the instruction) (default: state,images,task, what a deployed robot has, of "
        "those the dataset carries)",
    )
    frame_cache: Literal["auto", "memory", "disk"] = setting(
        "auto",
        "where the decoded frames are kept while training: memory, or disk (a uint8 cache beside the dataset, built "
        "on the first run, read a batch at a time); auto: disk when they would take more than half the memory "
        "available",
    )
    policy: dict = setting(default_factory=dict, help="fields of the policy's LeRobot config", cli=False)

    @classmethod
    def load(cls, path: str | Path | None = None, **overrides) -> TrainConfig:
        """Defaults, then the YAML file ``path`` (if any), then ``overrides`` (None: not given)."""
        return config.load(cls, path, overrides=overrides)
