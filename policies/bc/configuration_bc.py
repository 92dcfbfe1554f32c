"""BCConfig: the behaviour-cloning policy's settings, registered with LeRobot as policy type ``gloverec_bc``.

Inputs: ``observation.state``, ``observation.environment_state`` and, when the dataset has cameras,
``observation.images.*``. Other dataset features LeRobot offers as inputs (``observation.glove``: the human
hand, which a deployed robot does not have) are dropped by ``validate_features``. Output: ``action`` chunks of
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

POLICY_TYPE = "gloverec_bc"


@PreTrainedConfig.register_subclass(POLICY_TYPE)
@dataclass
class BCConfig(PreTrainedConfig):
    n_obs_steps: int = 1
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

    # the network: an MLP over the normalised state vectors and the image embeddings
    hidden_dim: int = 512
    n_layers: int = 3
    dropout: float = 0.0
    use_images: bool = True
    image_channels: tuple[int, ...] = (32, 64, 64)  # the per-camera CNN (stride-2 convolutions, then global pooling)
    image_embedding_dim: int = 64
    # a free-wrist dataset (action base.x/y/z, state palm.x/y/z): positions and the base target relative to the
    # palm (policies/bc/palm_frame.py); no effect on other datasets
    palm_frame: bool = True
    palm_frame_scale_m: float = 0.01  # the base target's loss counts its error per this much (see palm_frame.py)

    # the dataset's feature names, filled by LeRobot's make_policy (set_dataset_feature_metadata)
    state_feature_names: list[str] | None = None
    environment_state_feature_names: list[str] | None = None
    action_feature_names: list[str] | None = None

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
        if self.n_obs_steps != 1:
            raise ValueError(f"only n_obs_steps=1 is supported, got {self.n_obs_steps}")
        if self.hidden_dim < 1 or self.n_layers < 1:
            raise ValueError("hidden_dim and n_layers must be positive")

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

    def validate_features(self) -> None:
        """Keep the inputs the policy reads (state, environment state, images) and check there is one."""
        used = {}
        for key, ft in (self.input_features or {}).items():
            if key in (OBS_STATE, OBS_ENV_STATE) or (ft.type is FeatureType.VISUAL and self.use_images):
                used[key] = ft
        self.input_features = used
        if not used:
            raise ValueError(
                f"the {POLICY_TYPE} policy needs {OBS_STATE}, {OBS_ENV_STATE} or images among its "
                "inputs; none was given"
            )
        if not self.output_features or ACTION not in self.output_features:
            raise ValueError(f"the {POLICY_TYPE} policy needs an '{ACTION}' output feature")

    @property
    def observation_delta_indices(self) -> None:
        return None

    @property
    def action_delta_indices(self) -> list[int]:
        return list(range(self.chunk_size))

    @property
    def reward_delta_indices(self) -> None:
        return None
