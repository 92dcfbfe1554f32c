"""BCConfig: the behaviour-cloning policy's settings, registered with LeRobot as policy type ``gloverec_bc``.

Inputs by name (``inputs``, policies/inputs.py): ``state`` (the robot's own elements of ``observation.state``),
``environment`` (``observation.environment_state`` and the task's elements inside ``observation.state``),
``images`` (``observation.images.*``) and ``task`` (the instruction, through a learned embedding of each of the
training set's ``instructions``). The default is what a deployed robot has: state, images and task, of those the
dataset carries. Other dataset features LeRobot offers as inputs (``observation.glove``: the human hand, which a
deployed robot does not have) are dropped by ``validate_features``. Output: ``action`` chunks of
``chunk_size`` steps; at inference the chunks predicted at every step are blended by temporal ensembling
(lerobot's ACTTemporalEnsembler), or, with ``temporal_ensemble_coeff: null``, ``n_action_steps`` of each chunk
are executed before predicting again.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from lerobot.configs.policies import PreTrainedConfig
from lerobot.configs.types import FeatureType, NormalizationMode
from lerobot.optim.optimizers import AdamWConfig
from lerobot.optim.schedulers import CosineDecayWithWarmupSchedulerConfig
from lerobot.utils.constants import ACTION, OBS_ENV_STATE, OBS_STATE

from policies import inputs as named_inputs

POLICY_TYPE = "gloverec_bc"


@PreTrainedConfig.register_subclass(POLICY_TYPE)
@dataclass
class BCConfig(PreTrainedConfig):
    # history: the policy sees n_obs_steps observations of its vector inputs (state, environment), the newest and
    # n_obs_steps - 1 before it, obs_stride frames apart (4 and 8 at 30 fps: the last second); cameras only the
    # newest frame. At an episode's start the first observation stands in for the ones before it (LeRobot's
    # padding repeats an episode's first frame; select_action fills its window with it after reset()).
    n_obs_steps: int = 1
    obs_stride: int = 1
    chunk_size: int = 10  # actions predicted per observation (steps of the dataset's fps)
    n_action_steps: int = 1  # executed per prediction (1 with temporal ensembling)
    temporal_ensemble_coeff: float | None = 0.1  # w_i = exp(-coeff * i), i = 0 the oldest prediction

    normalization_mapping: dict[str, NormalizationMode] = field(
        default_factory=lambda: {
            "VISUAL": NormalizationMode.MEAN_STD,
            "STATE": NormalizationMode.MEAN_STD,
            "ENV": NormalizationMode.MEAN_STD,
            "ACTION": NormalizationMode.MEAN_STD,
        }
    )

    # what the policy reads, by name (policies/inputs.py): state, environment, images (or images.CAMERA), task
    inputs: list[str] = field(default_factory=lambda: list(named_inputs.ROBOT))

    # the network: an MLP over the normalised state vectors, the image embeddings and the instruction's embedding
    hidden_dim: int = 512
    n_layers: int = 3
    dropout: float = 0.0
    use_images: bool = True
    # the per-camera CNN: stride-2 convolutions (the last with stride 1), then spatial-softmax keypoints
    # (robomimic, Diffusion Policy: where things are, which a global pool loses); GroupNorm, no BatchNorm
    image_channels: tuple[int, ...] = (32, 32, 32)
    image_keypoints: int = 32
    image_embedding_dim: int = 64
    # training augmentation: random shifts by up to this many pixels (DrQ), 0 off (the default: 4 px moved HandKeys'
    # lit key onto its neighbour's place in an 84 px image, 8 % against 100 %; HandGrasp 94 % against 96 %)
    image_shift: int = 0
    # training augmentation for the vector inputs: Gaussian noise of this std (in normalised units) added to each,
    # 0 off (docs/policies.md, diagnosis: what it does against a policy that leaves the demonstrated states)
    input_noise: float = 0.0
    task_embedding_dim: int = 32
    # the instructions the embedding knows: the training set's, and every other one its task can draw (an
    # embedding row never trained); one outside them is an error
    instructions: list[str] | None = None
    trained_instructions: list[str] | None = None  # those the training set had
    # a free-wrist dataset (action base.x/y/z, state palm.x/y/z): positions and the base target relative to the
    # palm (policies/bc/palm_frame.py); no effect on other datasets
    palm_frame: bool = True
    palm_frame_scale_m: float = 0.01  # the base target's loss counts its error per this much (see palm_frame.py)

    # the dataset's feature names, filled by LeRobot's make_policy (set_dataset_feature_metadata)
    state_feature_names: list[str] | None = None
    environment_state_feature_names: list[str] | None = None
    action_feature_names: list[str] | None = None
    state_indices: list[int] | None = None  # the elements of observation.state the inputs keep (None: all)

    # training preset (lerobot-train uses it too)
    optimizer_lr: float = 1e-3
    optimizer_weight_decay: float = 1e-4
    optimizer_grad_clip_norm: float = 10.0
    scheduler_warmup_steps: int = 200
    scheduler_decay_steps: int = 20_000  # auto-scaled down to shorter runs by lerobot's scheduler
    scheduler_decay_lr: float = 1e-5

    def __post_init__(self):
        super().__post_init__()
        if self.chunk_size < 1:
            raise ValueError(f"chunk_size must be at least 1, got {self.chunk_size}")
        if not 1 <= self.n_action_steps <= self.chunk_size:
            raise ValueError(f"n_action_steps must be in 1..chunk_size ({self.chunk_size}), got {self.n_action_steps}")
        if self.temporal_ensemble_coeff is not None and self.n_action_steps != 1:
            raise ValueError("n_action_steps must be 1 with temporal ensembling (the policy runs every step)")
        if self.n_obs_steps < 1 or self.obs_stride < 1:
            raise ValueError(
                f"n_obs_steps and obs_stride must be at least 1, got {self.n_obs_steps} and {self.obs_stride}"
            )
        if self.hidden_dim < 1 or self.n_layers < 1:
            raise ValueError("hidden_dim and n_layers must be positive")
        self.inputs = list(named_inputs.parse(self.inputs))

    def get_optimizer_preset(self) -> AdamWConfig:
        return AdamWConfig(
            lr=self.optimizer_lr, weight_decay=self.optimizer_weight_decay, grad_clip_norm=self.optimizer_grad_clip_norm
        )

    def get_scheduler_preset(self) -> CosineDecayWithWarmupSchedulerConfig:
        return CosineDecayWithWarmupSchedulerConfig(
            num_warmup_steps=self.scheduler_warmup_steps,
            num_decay_steps=self.scheduler_decay_steps,
            peak_lr=self.optimizer_lr,
            decay_lr=self.scheduler_decay_lr,
        )

    def set_dataset_feature_metadata(self, features: dict) -> None:
        """Keep the names of the vector features (LeRobot's make_policy calls this with the dataset's)."""
        names = lambda key: list(features[key]["names"]) if features.get(key, {}).get("names") else None  # noqa: E731
        self.state_feature_names = names(OBS_STATE)
        self.environment_state_feature_names = names(OBS_ENV_STATE)
        self.action_feature_names = names(ACTION)
        self.state_indices = named_inputs.state_indices(self.state_feature_names, tuple(self.inputs))

    def set_instructions(self, trained, others=()) -> None:
        """The training set's instructions (a LeRobot dataset's tasks) and the others its task can draw, unless
        set already."""
        if self.instructions is None:
            self.trained_instructions = sorted({str(t) for t in trained})
            self.instructions = sorted({*self.trained_instructions, *map(str, others)})

    @property
    def reads_task(self) -> bool:
        """The instruction is an input: asked for, and the training set had more than one (a constant one, as a
        lerobot-record dataset's --dataset.single_task, tells the policy nothing)."""
        return "task" in self.inputs and len(self.trained_instructions or self.instructions or ()) > 1

    def validate_features(self) -> None:
        """Keep the inputs the policy reads (``inputs``: state, environment state, images) and check there is one."""
        named = tuple(self.inputs)
        used = {}
        for key, ft in (self.input_features or {}).items():
            if key == OBS_STATE:
                keep = ("state" in named or "environment" in named) and self.state_indices != []
            elif key == OBS_ENV_STATE:
                keep = "environment" in named
            else:
                keep = ft.type is FeatureType.VISUAL and self.use_images and named_inputs.reads_image(key, named)
            if keep:
                used[key] = ft
        self.input_features = used
        if not used and not self.reads_task:
            raise ValueError(
                f"the {POLICY_TYPE} policy reads nothing: none of its inputs ({', '.join(named)}) is in the dataset"
            )
        if not self.output_features or ACTION not in self.output_features:
            raise ValueError(f"the {POLICY_TYPE} policy needs an '{ACTION}' output feature")

    @property
    def history_frames(self) -> int:
        """How many frames the observation window spans (1: the newest only)."""
        return (self.n_obs_steps - 1) * self.obs_stride + 1

    @property
    def observation_delta_indices(self) -> list[int] | None:
        if self.n_obs_steps == 1:
            return None
        return list(range(-(self.n_obs_steps - 1) * self.obs_stride, 1, self.obs_stride))

    @property
    def action_delta_indices(self) -> list[int]:
        return list(range(self.chunk_size))

    @property
    def reward_delta_indices(self) -> None:
        return None
