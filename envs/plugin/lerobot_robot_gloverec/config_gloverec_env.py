"""GloverecEnvConfig: `--env.type=gloverec` on LeRobot's command line, for lerobot-eval and lerobot-train's
``--env_eval_freq``: a gloverec task on a robot hand as LeRobot's vector environments (gloverec_env.py)."""

from __future__ import annotations

from dataclasses import dataclass, field

from lerobot.configs import FeatureType, PolicyFeature
from lerobot.envs.configs import EnvConfig
from lerobot.utils.constants import ACTION, OBS_ENV_STATE, OBS_IMAGES, OBS_STATE

from lerobot_robot_gloverec.gloverec_env import make_vector_env, spaces_of


@EnvConfig.register_subclass("gloverec")
@dataclass
class GloverecEnvConfig(EnvConfig):
    """``task``: a registered task (pose, grasp, pinch, keys, turn, ...); ``robot``: a gloverec robot hand;
    ``fps``: the control rate the policy was trained at (its dataset's fps); ``cameras``: the scene's cameras the
    policy reads (front, top, side: ``--env.cameras='[front]'``), at ``image_size`` (height, width);
    ``state_includes_task``: the task's state inside ``observation.state``, as in a lerobot-record gloverec_sim
    dataset (a `gloverec record` dataset keeps it in ``observation.environment_state``); ``base_position``: a free
    wrist (the action places the palm); ``episode_s``: None for the task's own length."""

    task: str = "pose"
    robot: str = "glovehand"
    fps: int = 30
    cameras: list[str] = field(default_factory=list)
    image_size: tuple[int, int] = (128, 128)
    state_includes_task: bool = False
    base_position: bool = False
    episode_s: float | None = None

    def __post_init__(self):
        # the shapes come from the task itself (one environment built and closed), so they cannot drift from it
        obs, action = spaces_of(self.task, self.robot, self.gym_kwargs)
        self.features = {ACTION: PolicyFeature(type=FeatureType.ACTION, shape=action.shape)}
        self.features_map = {ACTION: ACTION, "agent_pos": OBS_STATE}
        self.features["agent_pos"] = PolicyFeature(type=FeatureType.STATE, shape=obs["agent_pos"].shape)
        if "environment_state" in obs.spaces:
            self.features["environment_state"] = PolicyFeature(
                type=FeatureType.ENV, shape=obs["environment_state"].shape
            )
            self.features_map["environment_state"] = OBS_ENV_STATE
        for cam in self.cameras:
            self.features[f"pixels/{cam}"] = PolicyFeature(type=FeatureType.VISUAL, shape=obs["pixels"][cam].shape)
            self.features_map[f"pixels/{cam}"] = f"{OBS_IMAGES}.{cam}"

    @property
    def gym_kwargs(self) -> dict:
        """The task's options (envs.make's keywords besides the task and robot)."""
        kwargs = {
            "render_mode": "rgb_array",  # lerobot-eval films the first episodes
            "control_hz": float(self.fps),
            "cameras": tuple(self.cameras),
            "image_size": tuple(self.image_size),
            "state_includes_task": self.state_includes_task,
            "base_position": self.base_position,
        }
        if self.episode_s is not None:
            kwargs["episode_s"] = self.episode_s
        return kwargs

    def create_envs(self, n_envs: int, use_async_envs: bool = False):
        return {self.type: {0: make_vector_env(self.task, self.robot, self.gym_kwargs, n_envs, use_async_envs)}}
