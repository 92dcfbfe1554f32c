"""BCPolicy: behaviour cloning with action chunking, as a LeRobot PreTrainedPolicy.

    [observation.state (the kept elements) | observation.environment_state | CNN(image) per camera
     | embedding(instruction)]  (normalised by the processor)
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
from lerobot.policies.diffusion.modeling_diffusion import SpatialSoftmax
from lerobot.policies.pretrained import PreTrainedPolicy
from lerobot.utils.constants import ACTION, OBS_ENV_STATE, OBS_STATE
from torch import Tensor, nn

from policies.bc.configuration_bc import POLICY_TYPE, BCConfig
from policies.bc.palm_frame import PalmFrame, palm_frame_indices
from policies.inputs import task_instructions


class ImageEncoder(nn.Module):
    """A small CNN for 84-128 px images: stride-2 convolutions (the last with stride 1) with GroupNorm, then
    spatial-softmax keypoints (LeRobot's SpatialSoftmax, from robomimic) and a linear embedding."""

    def __init__(self, channels: tuple[int, ...], keypoints: int, out_dim: int, image_shape: tuple[int, int]):
        super().__init__()
        layers, c_in = [], 3
        h, w = image_shape
        for i, c in enumerate(channels):
            k, stride = (5, 2) if i == 0 else (3, 2 if i < len(channels) - 1 else 1)
            layers += [nn.Conv2d(c_in, c, k, stride=stride, padding=k // 2), nn.GroupNorm(min(8, c), c), nn.GELU()]
            h, w = (h + stride - 1) // stride, (w + stride - 1) // stride
            c_in = c
        self.net = nn.Sequential(*layers)
        self.keypoints = SpatialSoftmax((c_in, h, w), num_kp=keypoints)
        self.out = nn.Sequential(nn.Flatten(), nn.Linear(2 * keypoints, out_dim), nn.GELU())

    def forward(self, image: Tensor) -> Tensor:
        return self.out(self.keypoints(self.net(image)))


def random_shift(images: Tensor, pad: int) -> Tensor:
    """DrQ's augmentation: pad by replicating the border, crop back at a random offset per image."""
    n, _, h, w = images.shape
    padded = F.pad(images, (pad, pad, pad, pad), mode="replicate")
    dy, dx = torch.randint(0, 2 * pad + 1, (2, n)).tolist()
    return torch.stack([padded[i, :, y : y + h, x : x + w] for i, (y, x) in enumerate(zip(dy, dx))])


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
        meta = kwargs.get("dataset_meta")
        if config.instructions is None and meta is not None:  # lerobot-train's make_policy
            config.set_instructions(meta.tasks.index, task_instructions(meta.root))
        self.encoders = nn.ModuleList(
            ImageEncoder(
                tuple(config.image_channels),
                config.image_keypoints,
                config.image_embedding_dim,
                tuple(config.input_features[k].shape[1:]),
            )
            for k in self.image_keys
        )
        self.task_ids = {text: i for i, text in enumerate(config.instructions or ())} if config.reads_task else {}
        self.task_embedding = nn.Embedding(len(self.task_ids), config.task_embedding_dim) if self.task_ids else None
        self.register_buffer(
            "state_indices",
            torch.tensor(config.state_indices if config.state_indices is not None else [], dtype=torch.long),
            persistent=False,
        )
        state_width = {OBS_STATE: len(config.state_indices)} if config.state_indices is not None else {}
        width = (
            config.n_obs_steps * sum(state_width.get(k, config.input_features[k].shape[0]) for k in self.vector_keys)
            + config.image_embedding_dim * len(self.image_keys)
            + (config.task_embedding_dim if self.task_embedding is not None else 0)
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
        self._history = {k: deque(maxlen=self.config.history_frames) for k in self.vector_keys}

    def adopt_stats(self, stats: dict) -> None:
        """The statistics the processors normalise with, where the model needs them too (the palm frame)."""
        if self.palm_frame is not None:
            self.palm_frame.adopt(stats)

    def _windows(self, batch: dict[str, Tensor]) -> dict[str, Tensor]:
        """Each vector input as (B, n_obs_steps, D): a training batch's window (LeRobot's observation deltas), or at
        inference the newest observation appended to the window kept since reset()."""
        n, out = self.config.n_obs_steps, {}
        for k in self.vector_keys:
            x = batch[k]
            if x.dim() == 3:  # (B, n, D): a window from the dataset
                out[k] = x
                continue
            if n == 1:
                out[k] = x.unsqueeze(1)
                continue
            queue = self._history[k]
            while len(queue) < queue.maxlen - 1:  # after reset(): the first observation stands in for the past
                queue.append(x)
            queue.append(x)
            out[k] = torch.stack(list(queue)[:: self.config.obs_stride], dim=1)
        return out

    def _chunk(self, batch: dict[str, Tensor]) -> Tensor:
        windows = self._windows(batch)
        b, n = next(iter(windows.values())).shape[:2] if windows else (0, 1)
        vectors = {k: v.flatten(0, 1) for k, v in windows.items()}  # (B * n, D): each step alike
        if self.training and self.config.input_noise > 0:
            vectors = {k: v + self.config.input_noise * torch.randn_like(v) for k, v in vectors.items()}
        if self.palm_frame is not None:
            vectors, palm = self.palm_frame.inputs(vectors)
            palm = palm.view(b, n, -1)[:, -1]  # the base target is relative to the newest palm
        if OBS_STATE in vectors and self.config.state_indices is not None:
            vectors[OBS_STATE] = vectors[OBS_STATE][:, self.state_indices]  # the task's elements left out
        parts = [vectors[k].reshape(b, -1) for k in self.vector_keys]
        for enc, k in zip(self.encoders, self.image_keys):
            image = batch[k]
            if image.dim() == 5:  # (B, n, C, H, W) from lerobot-train's observation deltas: the newest frame
                image = image[:, -1]
            if self.training and self.config.image_shift > 0:
                image = random_shift(image, self.config.image_shift)
            parts.append(enc(image))
        if self.task_embedding is not None:
            parts.append(self.task_embedding(self.instruction_ids(batch["task"], parts[0].shape[0] if parts else 1)))
        x = self.mlp(torch.cat(parts, dim=-1))
        chunk = self.head(x).view(-1, self.config.chunk_size, self.action_dim)
        return chunk if self.palm_frame is None else self.palm_frame.outputs(chunk, palm)

    def instruction_ids(self, tasks, n: int) -> Tensor:
        """The embedding rows of a batch's instructions (one string is every row's); ValueError for an
        instruction the training set did not have."""
        tasks = [tasks] * n if isinstance(tasks, str) else list(tasks)
        try:
            return torch.tensor([self.task_ids[t] for t in tasks], dtype=torch.long)
        except KeyError as exc:
            known = "; ".join(repr(t) for t in self.task_ids)
            raise ValueError(f"the policy does not know the instruction {exc.args[0]!r} (it knows {known})") from None

    @torch.no_grad()
    def predict_action_chunk(self, batch: dict[str, Tensor], **kwargs) -> Tensor:
        """(B, chunk_size, action_dim) normalised actions for a (normalised) observation batch."""
        self.eval()
        return self._chunk(batch)

    @torch.no_grad()
    def select_action(self, batch: dict[str, Tensor], **kwargs) -> Tensor:
        """(B, action_dim): the next action, temporally ensembled (or from the chunk queue)."""
        self.eval()
        batch = {**batch, **self._windows(batch)}  # every step's observation joins the window, predicted or not
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
