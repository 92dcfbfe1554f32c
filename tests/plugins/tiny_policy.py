"""A policy type from outside the package, in one module (docs/policies.md, "Adding a policy type"): a linear map
from the robot's joint state to the action, registered with LeRobot as ``tiny_linear``.

LeRobot's factory finds the policy and its processors by name from the registered config class ``<Name>Config``:
``<Name>Policy`` and ``make_<type>_pre_post_processors`` in the config's module with ``configuration_`` replaced by
``modeling_`` and ``processor_`` (lerobot/policies/factory.py): in a module without that word, this one."""

from dataclasses import dataclass, field

import torch
from lerobot.configs.policies import PreTrainedConfig
from lerobot.configs.types import NormalizationMode
from lerobot.optim.optimizers import AdamConfig
from lerobot.policies.pretrained import PreTrainedPolicy
from lerobot.processor import (
    AddBatchDimensionProcessorStep,
    DeviceProcessorStep,
    NormalizerProcessorStep,
    PolicyProcessorPipeline,
    UnnormalizerProcessorStep,
)
from lerobot.processor.converters import policy_action_to_transition, transition_to_policy_action
from lerobot.utils.constants import (
    ACTION,
    OBS_STATE,
    POLICY_POSTPROCESSOR_DEFAULT_NAME,
    POLICY_PREPROCESSOR_DEFAULT_NAME,
)
from torch import nn

POLICY_TYPE = "tiny_linear"


@PreTrainedConfig.register_subclass(POLICY_TYPE)
@dataclass
class TinyLinearConfig(PreTrainedConfig):
    optimizer_lr: float = 1e-3  # the name `gloverec train --lr` sets (LeRobot's policies call it so too)
    normalization_mapping: dict[str, NormalizationMode] = field(
        default_factory=lambda: {"STATE": NormalizationMode.MEAN_STD, "ACTION": NormalizationMode.MEAN_STD}
    )

    observation_delta_indices = None  # one frame in, one action out: no chunks, no history
    action_delta_indices = None
    reward_delta_indices = None

    def get_optimizer_preset(self) -> AdamConfig:
        return AdamConfig(lr=self.optimizer_lr)

    def get_scheduler_preset(self) -> None:
        return None

    def validate_features(self) -> None:
        # the robot's joint state only: a deployed robot has no glove (observation.glove) and no simulator state
        self.input_features = {OBS_STATE: self.input_features[OBS_STATE]}


class TinyLinearPolicy(PreTrainedPolicy):
    config_class = TinyLinearConfig
    name = POLICY_TYPE

    def __init__(self, config: TinyLinearConfig, **kwargs):  # make_policy passes dataset_stats and dataset_meta too
        super().__init__(config)
        config.validate_features()
        self.net = nn.Linear(config.input_features[OBS_STATE].shape[0], config.output_features[ACTION].shape[0])

    def get_optim_params(self):
        return self.parameters()

    def reset(self) -> None:
        pass

    def forward(self, batch: dict) -> tuple[torch.Tensor, dict]:
        return (self.net(batch[OBS_STATE]) - batch[ACTION]).abs().mean(), {}

    def predict_action_chunk(self, batch: dict, **kwargs) -> torch.Tensor:
        return self.select_action(batch).unsqueeze(1)

    def select_action(self, batch: dict, **kwargs) -> torch.Tensor:
        return self.net(batch[OBS_STATE])


def make_tiny_linear_pre_post_processors(config: TinyLinearConfig, dataset_stats=None):
    """LeRobot's own steps (saved beside the weights, loaded back by name): normalise in, unnormalise out."""
    features = {**config.input_features, **config.output_features}
    norm = config.normalization_mapping
    pre = PolicyProcessorPipeline(
        steps=[
            AddBatchDimensionProcessorStep(),
            DeviceProcessorStep(device=config.device),
            NormalizerProcessorStep(features=features, norm_map=norm, stats=dataset_stats),
        ],
        name=POLICY_PREPROCESSOR_DEFAULT_NAME,
    )
    post = PolicyProcessorPipeline(
        steps=[UnnormalizerProcessorStep(features=config.output_features, norm_map=norm, stats=dataset_stats)],
        name=POLICY_POSTPROCESSOR_DEFAULT_NAME,
        to_transition=policy_action_to_transition,
        to_output=transition_to_policy_action,
    )
    return pre, post
