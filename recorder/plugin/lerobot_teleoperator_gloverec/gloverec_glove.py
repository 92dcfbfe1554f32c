"""GloverecGlove: gloverec's data glove as a LeRobot ``Teleoperator`` (`--teleop.type=gloverec_glove`).

The session is built as every gloverec command builds it (recorder/rig/rig.py, with no task: the teleoperator
drives a robot): the wearer's hand profile, the retargeter fitted to it, and the glove: any port, and any wire
format, fused into a HandPose on the host where the glove sends raw IMU frames (with its saved calibration). Each
``get_action`` takes the newest pose and retargets it onto the robot it drives: a gloverec robot hand (the
``joint`` map or fingertip ``ik``, as `gloverec record` does; the keys are gloverec_sim's action keys) or a real
hand's motor map (the HopeJR hand's 16 tendon motors, 0..100). It never waits for the glove: when no new pose has
come for more than three glove intervals (50 ms at least) it returns the last action and logs the stall once, and
again when poses come back.
"""

from __future__ import annotations

import dataclasses
import logging
import time

from lerobot.teleoperators.teleoperator import Teleoperator
from lerobot.utils.errors import DeviceAlreadyConnectedError, DeviceNotConnectedError

from envs.robots import robot_names
from envs.tasks.base import action_names
from lerobot_teleoperator_gloverec.config_gloverec_glove import GloverecGloveConfig
from recorder.calibrate.procedure import Calibrator
from recorder.config import ConfigError
from recorder.glove.config import GloveConfig
from recorder.glove.glove import Glove
from recorder.hand.pose import HandPose
from recorder.lerobot_names import lerobot_action_name
from recorder.paths import calibration_dir
from recorder.retarget import Retargeter
from recorder.retarget.motor_map import MotorMap, load_motor_map, motor_map_names
from recorder.rig.config import SessionConfig
from recorder.rig.rig import Rig
from recorder.speech import warn_if_prompts_will_fail

logger = logging.getLogger(__name__)
STALE_INTERVALS = 3.0  # no new pose for this many glove intervals (and at least STALE_MIN_S): the pose is stale
STALE_MIN_S = 0.05  # a loaded machine delays a healthy glove's frames by tens of milliseconds


class _RobotHand:
    """A gloverec robot hand driven through the rig's Retargeter (its base turned by the palm): gloverec_sim's
    action keys."""

    def __init__(self, retarget: Retargeter):
        self.retarget = retarget
        self.names = [lerobot_action_name(n) for n in action_names(self.retarget.robot, base_rotation=True)]

    def __call__(self, pose: HandPose) -> dict[str, float]:
        action, _ = self.retarget(pose.angles, pose.palm)
        return dict(zip(self.names, action.tolist()))


def _target(robot: str, rig: Rig) -> _RobotHand | MotorMap:
    if rig.retarget is not None:  # a gloverec robot hand
        return _RobotHand(rig.retarget)
    if robot in motor_map_names():
        return load_motor_map(robot)
    raise ConfigError(
        f"gloverec_glove: unknown robot {robot!r}; robot hands: {', '.join(robot_names())}; "
        f"motor maps: {', '.join(motor_map_names())}"
    )


class GloverecGlove(Teleoperator):
    config_class = GloverecGloveConfig
    name = "gloverec_glove"

    def __init__(self, config: GloverecGloveConfig):
        config = dataclasses.replace(config, calibration_dir=calibration_dir(config.calibration_dir))
        super().__init__(config)
        self.config = config
        self.glove_config = GloveConfig.parse(config.port, mode=config.emulator_output)  # a bad port: one line
        self.glove_id = _hex(config.glove_id)
        session = SessionConfig(glove=self.glove_config, robot=config.robot, retarget=config.retarget,
                                wearer=config.wearer)  # fmt: skip
        # a missing or impossible profile: one line, before any glove opens (motor maps take angles, not sizes)
        self.rig = Rig(session, env=False, folder=config.calibration_dir)
        self.profile = self.rig.profile
        self.target = _target(config.robot, self.rig)
        self.glove: Glove | None = None
        self._action: dict[str, float] | None = None
        self._fresh = 0.0  # host time at which the glove sampled the newest pose taken
        self._stalled = False

    # ------------------------------------------------------------ features
    @property
    def action_features(self) -> dict:
        return {name: float for name in self.target.names}

    @property
    def feedback_features(self) -> dict:
        return {}

    # ------------------------------------------------------------ lifecycle
    @property
    def is_connected(self) -> bool:
        return self.glove is not None

    def connect(self, calibrate: bool = True) -> None:
        """Open the glove and wait for its first hand pose; a glove that is absent or silent: one-line error.
        ``calibrate``: a glove fused on the host without a saved calibration is calibrated first."""
        if self.is_connected:
            raise DeviceAlreadyConnectedError(f"{self} is already connected")
        warn_if_prompts_will_fail(self.name)
        self.glove = self._open()
        if calibrate and not self.is_calibrated:
            self.calibrate()

    def _open(self) -> Glove:
        glove = self.rig.wear(motion=self.config.emulator_motion, calibration_dir=self.config.calibration_dir).glove
        glove.open()
        pose = glove.latest(wait_s=self.config.first_pose_s)
        if pose is None:
            glove.close()
            raise ConnectionError(
                f"gloverec_glove: no hand pose from {self.glove_config} in {self.config.first_pose_s:g} s: "
                "is it a glove, connected and sending?"
            )
        self._action, self._fresh, self._stalled = self.target(pose), self._sampled(glove), False
        return glove

    @property
    def is_calibrated(self) -> bool:
        """True when the glove fuses on board or its saved calibration is in use (or, before connecting, saved
        for ``glove_id``)."""
        if self.glove is not None:
            record = self.glove.fusion.record or {}
            return not record.get("host_fusion") or bool(record.get("calibrated"))
        if self.glove_id is None:
            return True  # unknown until the glove says who it is
        return (self.config.calibration_dir / f"glove_{self.glove_id:08x}.json").is_file()

    def calibrate(self) -> None:
        """`gloverec calibrate`'s steps on this glove (its instructions on stderr), saved under its id."""
        was_open = self.glove is not None
        if was_open:
            self.glove.close()
            self.glove = None
        Calibrator(self.glove_config, glove_id=self.glove_id, folder=self.config.calibration_dir).run()
        if was_open:
            self.glove = self._open()

    def configure(self) -> None:
        pass

    def disconnect(self) -> None:
        if not self.is_connected:
            raise DeviceNotConnectedError(f"{self} is not connected")
        self.glove.close()
        self.glove = None

    # ------------------------------------------------------------ the loop
    def get_action(self) -> dict[str, float]:
        """The robot's action for the newest hand pose; never waits for the glove (a stale pose is held)."""
        if not self.is_connected:
            raise DeviceNotConnectedError(f"{self} is not connected")
        now = time.monotonic()
        if self.glove.poll() > 0:
            if self._stalled:
                logger.info("%s: hand poses again after %.0f ms", self, (now - self._fresh) * 1e3)
            self._action, self._fresh, self._stalled = (
                self.target(self.glove.track.newest),
                self._sampled(self.glove),
                False,
            )
        elif not self._stalled and now - self._fresh > max(STALE_INTERVALS * self._interval(), STALE_MIN_S):
            self._stalled = True
            logger.warning(
                "%s: no hand pose from %s for %.0f ms: holding the last one",
                self,
                self.glove_config,
                (now - self._fresh) * 1e3,
            )
        return dict(self._action)

    @staticmethod
    def _sampled(glove: Glove) -> float:
        """When the newest pose was sampled (host monotonic s): a pose's age counts from there, not from when it
        was taken, so frames that were queued before the glove went silent do not look fresh."""
        t = glove.track.newest_s
        return time.monotonic() if t is None else t

    def _interval(self) -> float:
        return self.glove.track.interval_s(1.0 / self.glove_config.rate_hz)

    def __str__(self) -> str:
        return f"gloverec_glove({self.glove_config} -> {self.config.robot})"

    def send_feedback(self, feedback: dict) -> None:
        pass  # the glove has no actuators


def _hex(text: str | None) -> int | None:
    if text is None:
        return None
    try:
        value = int(str(text), 16)
    except ValueError:
        value = -1
    if not 0 < value < 1 << 32:
        raise ConfigError(f"gloverec_glove: glove_id must be a glove id in hex (1 to ffffffff), got {text!r}")
    return value
