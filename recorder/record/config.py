"""RecordConfig: what `gloverec record` does. The defaults are here; `--config FILE` (a YAML file of these keys,
e.g. configs/record/shadow_grasp.yaml) and then the command-line flags override them (recorder/config.py)."""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Literal

from pydantic import AfterValidator

from recorder import config as cfg
from recorder.config import NonNegative, Positive, setting
from recorder.glove.config import GloveConfig
from recorder.paths import recordings_dir
from recorder.record import precedence
from recorder.rig.config import SessionConfig
from recorder.view.config import View, view_setting

REPO_ID = re.compile(r"^[A-Za-z0-9][A-Za-z0-9._-]*/[A-Za-z0-9][A-Za-z0-9._-]*$")
CAMERAS = ("front", "top", "side")


def repo_id(value: str) -> str:
    """A dataset id USER/NAME; ValueError otherwise."""
    if not REPO_ID.match(value or "") or ".." in value:
        raise ValueError(f"bad repo id {value!r}: expected USER/NAME (letters, digits, . _ -)")
    return value


RepoId = Annotated[str, AfterValidator(repo_id)]


@dataclass
class RecordConfig(SessionConfig):
    """The session (SessionConfig: glove, robot, task, retargeting, wearer, wrist) and how it is recorded."""

    fps: Annotated[int, Positive] = setting(30, "dataset frames per second (the environment's control rate)")
    episodes: Annotated[int, Positive] = setting(10, "episodes to save")
    episode_time_s: Annotated[float, Positive] | None = setting(None, "longest episode (default: the task's)")
    reset_time_s: Annotated[float, NonNegative] = setting(
        2.0, "pause between episodes; the glove's button or → starts the next one early"
    )
    repo_id: RepoId = setting("local/glove_demos", "dataset id, USER/NAME")
    root: str | None = setting(None, "dataset folder (default: datasets/recordings/USER/NAME)")
    resume: bool = setting(False, "add episodes to an existing recording", flag="--resume")
    cameras: tuple[Literal["front", "top", "side"], ...] = setting(
        (), "comma-separated cameras to record (front, top, side)", metavar="CAM,CAM"
    )
    image_size: tuple[Annotated[int, Positive], Annotated[int, Positive]] = setting(
        (128, 128), "camera images, height and width", metavar="H,W"
    )
    realtime: bool | None = setting(
        None,
        "wall-clock pacing (default for serial and UDP gloves)",
        flag="--realtime",
        negation="--fast",
        negation_help="as fast as the glove delivers (default for the emulator and logs)",
    )
    demonstrator: Literal["scripted", "human"] = setting(
        "scripted",
        "the emulated wearer (--glove emulator): scripted (smooth, nearly always right) or human (reaction times, "
        "overshoot, hesitation, tremor, two strategies, failed takes; docs/envs.md)",
    )
    failure_rate: Annotated[float, NonNegative] = setting(
        0.15, "--demonstrator human: the share of takes the wearer gets wrong (0 to 1)"
    )
    open_loop: bool = setting(
        False,
        "the emulated wearer never looks at the robot hand: grasp and pinch close as planned, without the "
        "corrections a person watching the view makes (a benchmark's baseline)",
    )
    policy: str | None = setting(
        None,
        "a trained policy (a checkpoint or training folder) that drives the hand while the glove is read: the "
        "wearer takes over with t or the glove's button (takeover recording, docs/recording.md)",
        metavar="DIR",
    )
    takeover: bool = setting(
        False, "with --policy: the wearer also takes over by moving away from the policy's hand", flag="--takeover"
    )
    takeover_threshold: Annotated[float, Positive] = setting(
        0.15, "--takeover: the departure that counts (the largest share of an action element's range, 0 to 1)"
    )
    takeover_hold_s: Annotated[float, NonNegative] = setting(0.3, "--takeover: held this long, in seconds")
    dart: Annotated[float, NonNegative] = setting(
        0.0,
        "inject noise into the executed action (DART, docs/recording.md): its standard deviation as a share of each "
        "action element's range, e.g. 0.05 (0: off); the wearer's intended action is stored beside it",
        metavar="SCALE",
    )
    dart_time_s: Annotated[float, NonNegative] = setting(
        0.2, "--dart: how long the noise holds, its correlation time in seconds (0: white noise)"
    )
    seed: int = setting(0, "episode k of a session resets the environment with seed + k")
    log: bool = setting(True, "no raw MCAP log of the session beside the dataset", flag="--no-log")
    task_text: str | None = setting(None, "the task string stored with every frame (default: the task's)")
    view: View = view_setting(
        "live view: native (MuJoCo's viewer), web[:PORT] (a page on 127.0.0.1), rerun[:spawn|serve|connect|save], "
        "none (default: native with a display and a terminal, else none)"
    )

    @classmethod
    def load(cls, path: str | Path | None = None, **overrides) -> RecordConfig:
        """Defaults, then the YAML file ``path`` (if any), then ``overrides`` (None: not given)."""
        return cfg.load(cls, path, overrides=overrides)

    @property
    def glove_config(self) -> GloveConfig:
        """The glove, its emulated wearer seeded with the session's seed."""
        return GloveConfig.parse(self.glove, seed=self.seed)

    @property
    def is_fast(self) -> bool:
        return not self.glove.is_device if self.realtime is None else not self.realtime

    @property
    def root_path(self) -> Path:
        return Path(self.root) if self.root else recordings_dir() / self.repo_id

    def check(self) -> None:
        """What can be checked in a fraction of a second, before lerobot and torch load (seconds): the robot and
        the task by name, the task's settings and the episode length against the task's script. A problem is a
        one-line ConfigError naming the flag."""
        from envs import check_names, get_task  # MuJoCo (0.2 s): not at start-up

        check_names(self.robot, self.task)
        self.check_wrist_files()
        if not self.is_fast:
            precedence.wanted()  # a bad $GLOVEREC_LOOP_PRIORITY: one line, now
        if self.demonstrator != "scripted":
            from recorder.demonstrator import make_demonstrator  # the demonstrators: not at start-up

            if self.glove_config.kind != "emulator":
                raise cfg.ConfigError(f"--demonstrator {self.demonstrator} is the emulated wearer: record with "
                                      "--glove emulator")  # fmt: skip
            make_demonstrator(self.task, self.demonstrator, self.failure_rate)  # a task without one: one line
        if self.takeover and self.policy is None:
            raise cfg.ConfigError("--takeover passes control from a policy to the wearer: pass --policy DIR too")
        if self.dart and self.policy is not None:
            raise cfg.ConfigError("--dart perturbs the wearer's demonstrations: a takeover recording (--policy) "
                                  "takes none")  # fmt: skip
        if self.dart >= 1.0:
            raise cfg.ConfigError(f"--dart {self.dart:g}: expected a share of the action's range below 1")
        if self.policy is not None and not Path(self.policy).exists():
            raise cfg.ConfigError(f"--policy {self.policy}: no such folder")
        if self.policy is not None and self.takeover_threshold >= 1.0:
            raise cfg.ConfigError(f"--takeover-threshold {self.takeover_threshold:g}: expected a share below 1")
        task = get_task(self.task).config_class.load(self.task, **self.task_options())
        if self.episode_time_s is not None and self.episode_time_s <= task.min_episode_s():
            raise cfg.ConfigError(
                f"--episode-time-s {self.episode_time_s:g}: the {self.task} task's script takes "
                f"{task.min_episode_s():g} s, so its episodes must be longer (default {type(task)().episode_s:g} s)"
            )

    def task_options(self) -> dict:
        """The task's settings this recording gives (the rest are the task's defaults)."""
        options = {"control_hz": float(self.fps), "cameras": tuple(self.cameras), "image_size": tuple(self.image_size)}
        options.update(self.tracked_options())  # a tracked wrist: the wearer places the base
        if self.episode_time_s:
            options["episode_s"] = float(self.episode_time_s)
        return options
