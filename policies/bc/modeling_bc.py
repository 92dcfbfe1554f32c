"""BCPolicy: behaviour cloning with action chunking, as a LeRobot PreTrainedPolicy.

    [observation.state | observation.environment_state | CNN(image) per camera]  (normalised by the processor)
        -> MLP (n_layers x hidden_dim, GELU) -> chunk_size x action_dim   (normalised actions)

Trained with an L1 loss on the normalised action chunk (padding past an episode's end masked out, as ACT
does). At inference ``select_action`` predicts a chunk every step and blends the overlapping chunks with
lerobot's ACTTemporalEnsembler, or runs ``n_action_steps`` of each chunk from a queue.
"""

from __future__ import annotations

from collections import deque

import torch
import torch.nn.functional as F  # noqa: N812
from lerobot.policies.act.modeling_act import ACTTemporalEnsembler
from lerobot.policies.pretrained import PreTrainedPolicy
from lerobot.utils.constants import ACTION, OBS_ENV_STATE, OBS_STATE
from torch import Tensor, nn

from policies.bc.configuration_bc import POLICY_TYPE, BCConfig
from policies.bc.palm_frame import PalmFrame, palm_frame_indices


class ImageEncoder(nn.Module):
    """A small CNN: stride-2 convolutions, a 4x4 adaptive pool (keeps coarse layout), a linear embedding."""

    def __init__(self, channels: tuple[int, ...], out_dim: int):
        super().__init__()
        layers, c_in = [], 3
        for i, c in enumerate(channels):
            k = 5 if i == 0 else 3
            layers += [nn.Conv2d(c_in, c, k, stride=2, padding=k // 2), nn.GroupNorm(min(8, c), c), nn.GELU()]
            c_in = c
        self.net = nn.Sequential(
            *layers, nn.AdaptiveAvgPool2d(4), nn.Flatten(), nn.Linear(16 * c_in, out_dim), nn.GELU()
        )

    def forward(self, image: Tensor) -> Tensor:
        return self.net(image)


class BCPolicy(PreTrainedPolicy):
    config_class = BCConfig
    name = POLICY_TYPE

    def __init__(self, config: BCConfig, **kwargs):
        super().__init__(config)
        config.validate_features()
        self.config = config
        self.vector_keys = [k for k in (OBS_STATE, OBS_ENV_STATE) if k in config.input_features]
        self.image_keys = sorted(config.image_features)
        self.action_dim = config.action_feature.shape[0]
        self.encoders = nn.ModuleList(
            ImageEncoder(tuple(config.image_channels), config.image_embedding_dim) for _ in self.image_keys
        )
        width = sum(config.input_features[k].shape[0] for k in self.vector_keys) + config.image_embedding_dim * len(
            self.image_keys
        )
        layers = []
        for _ in range(config.n_layers):
            layers += [nn.Linear(width, config.hidden_dim), nn.LayerNorm(config.hidden_dim), nn.GELU()]
            if config.dropout > 0:
                layers.append(nn.Dropout(config.dropout))
            width = config.hidden_dim
        self.mlp = nn.Sequential(*layers)
        self.head = nn.Linear(width, config.chunk_size * self.action_dim)
        frame = palm_frame_indices(
            config.state_feature_names, config.environment_state_feature_names, config.action_feature_names
        )
        use_frame = config.palm_frame and frame is not None and OBS_STATE in self.vector_keys
        self.palm_frame = (
            PalmFrame(*frame, kwargs.get("dataset_stats"), config.palm_frame_scale_m) if use_frame else None
        )
        self.temporal_ensembler = (
            ACTTemporalEnsembler(config.temporal_ensemble_coeff, config.chunk_size)
            if config.temporal_ensemble_coeff is not None
            else None
        )
        self.reset()

    def get_optim_params(self):
        return self.parameters()

    def reset(self) -> None:
        """Call at every environment reset: forgets the chunks of the previous episode."""
        if self.temporal_ensembler is not None:
            self.temporal_ensembler.reset()
        self._queue = deque(maxlen=self.config.n_action_steps)

    def adopt_stats(self, stats: dict) -> None:
        """The statistics the processors normalise with, where the model needs them too (the palm frame)."""
        if self.palm_frame is not None:
            self.palm_frame.adopt(stats)

    def _chunk(self, batch: dict[str, Tensor]) -> Tensor:
        vectors = {k: batch[k].flatten(1) for k in self.vector_keys}
        if self.palm_frame is not None:
            vectors, palm = self.palm_frame.inputs(vectors)
        parts = [vectors[k] for k in self.vector_keys]
        parts += [enc(batch[k]) for enc, k in zip(self.encoders, self.image_keys)]
        x = self.mlp(torch.cat(parts, dim=-1))
        chunk = self.head(x).view(-1, self.config.chunk_size, self.action_dim)
        return chunk if self.palm_frame is None else self.palm_frame.outputs(chunk, palm)

    @torch.no_grad()
    def predict_action_chunk(self, batch: dict[str, Tensor], **kwargs) -> Tensor:
        """(B, chunk_size, action_dim) normalised actions for a (normalised) observation batch."""
        self.eval()
        return self._chunk(batch)

    @torch.no_grad()
    def select_action(self, batch: dict[str, Tensor], **kwargs) -> Tensor:
        """(B, action_dim): the next action, temporally ensembled (or from the chunk queue)."""
        self.eval()
        if self.temporal_ensembler is not None:
            return self.temporal_ensembler.update(self.predict_action_chunk(batch))
        if not self._queue:
            self._queue.extend(self.predict_action_chunk(batch)[:, : self.config.n_action_steps].transpose(0, 1))
        return self._queue.popleft()

    def forward(self, batch: dict[str, Tensor]) -> tuple[Tensor, dict]:
        """L1 loss between the predicted and the recorded (normalised) action chunks, padding masked out."""
        target = batch[ACTION]
        if target.dim() == 2:  # a dataset loaded without action chunks: a chunk of one
            target = target.unsqueeze(1)
        pred = self._chunk(batch)[:, : target.shape[1]]
        err = F.l1_loss(pred, target, reduction="none")
        if self.palm_frame is not None:
            err = err * self.palm_frame.loss_weights(self.action_dim)
        if "action_is_pad" in batch:
            keep = (~batch["action_is_pad"]).unsqueeze(-1).to(err.dtype)
            loss = (err * keep).sum() / (keep.sum() * err.shape[-1]).clamp(min=1.0)
        else:
            loss = err.mean()
        return loss, {"l1_loss": loss.item()}
