"""The palm frame: on a free-wrist dataset, the BC policy sees positions and predicts the base target relative to
the palm.

A free-wrist task (relocate, grasp or pinch with ``--wrist``) records the base target (``base.x/y/z``) in the
action and the palm's position (``palm.x/y/z``) in the state; the target is always within a few millimetres of
the palm. Predicted absolutely, the network learns to copy the palm and the millimetres that carry the reach get
lost among the centimetres of where the episode happens to be (relocate: 4 % success from 50 demonstrations).
In the palm frame the network sees every environment position (object, target) relative to the palm, not where
the palm is across the table (its height it keeps: the table is there), and predicts the base target as an offset
from the palm: a residual on the absolute action, so the loss, the normalisation and the temporal ensembling stay
in the dataset's absolute units (chunks predicted at different palm positions blend as absolute targets).

The processors normalise before the model, so the frame undoes and redoes the normalisation of the few values it
moves, with the statistics the processors use (buffers, saved with the weights).
"""

from __future__ import annotations

import torch
from torch import Tensor, nn

AXES = ("x", "y", "z")


def palm_frame_indices(state: list[str] | None, env: list[str] | None, action: list[str] | None):
    """(palm's state indices, base's action indices, [(environment index, axis)]) from the dataset's feature
    names, or None where the dataset has no free wrist (no ``base.x/y/z`` action or no ``palm.x/y/z`` state)."""
    if not state or not action:
        return None
    try:
        palm = [state.index(f"palm.{a}") for a in AXES]
        base = [action.index(f"base.{a}") for a in AXES]
    except ValueError:
        return None
    moved = []
    for i, name in enumerate(env or []):
        thing, _, axis = name.rpartition(".")
        if thing and axis in AXES:
            moved.append((i, AXES.index(axis)))
    return palm, base, moved


class PalmFrame(nn.Module):
    """Moves normalised inputs into the palm frame and normalised base targets out of it."""

    def __init__(
        self, palm: list[int], base: list[int], moved: list[tuple[int, int]], stats: dict | None, scale_m: float
    ):
        super().__init__()
        self.palm, self.base, self.scale_m = palm, base, scale_m
        self.env_idx = [i for i, _ in moved]
        self.env_axis = [a for _, a in moved]
        for name, _, idx in self._slots():  # loaded with the weights when no statistics are given
            self.register_buffer(f"{name}_mean", torch.zeros(len(idx)))
            self.register_buffer(f"{name}_std", torch.ones(len(idx)))
        if stats is not None:
            self.adopt(stats)

    def _slots(self) -> tuple:
        return (("palm", "observation.state", self.palm), ("base", "action", self.base),
                ("env", "observation.environment_state", self.env_idx))  # fmt: skip

    def adopt(self, stats: dict) -> None:
        """Take the statistics the processors normalise with (gloverec train computes its own)."""
        for name, key, idx in self._slots():
            if key in stats:
                getattr(self, f"{name}_mean").copy_(torch.as_tensor(stats[key]["mean"]).flatten()[idx])
                getattr(self, f"{name}_std").copy_(torch.as_tensor(stats[key]["std"]).flatten()[idx])

    def inputs(self, vectors: dict[str, Tensor]) -> tuple[dict[str, Tensor], Tensor]:
        """The normalised state and environment state in the palm frame, and the palm's position (m)."""
        state = vectors["observation.state"]
        palm = state[:, self.palm] * self.palm_std + self.palm_mean
        state = state.clone()
        state[:, self.palm[:2]] = 0.0  # where the palm is across the table: not an input
        out = {**vectors, "observation.state": state}
        env = vectors.get("observation.environment_state")
        if env is not None and self.env_idx:
            env = env.clone()
            where = env[:, self.env_idx] * self.env_std + self.env_mean
            env[:, self.env_idx] = (where - palm[:, self.env_axis]) / self.env_std
            out["observation.environment_state"] = env
        return out, palm

    def loss_weights(self, action_dim: int) -> Tensor:
        """Per action dimension: 1, but the base target's error counts per ``scale_m`` of offset from the palm, not
        per its spread across the table (a few centimetres: the offset is millimetres)."""
        w = torch.ones(action_dim, device=self.base_std.device)
        w[self.base] = self.base_std / self.scale_m
        return w

    def outputs(self, chunk: Tensor, palm: Tensor) -> Tensor:
        """The network's (B, chunk, action) output with its base dimensions as offsets from the palm -> the
        normalised absolute action chunk."""
        chunk = chunk.clone()
        chunk[:, :, self.base] = chunk[:, :, self.base] + ((palm - self.base_mean) / self.base_std)[:, None, :]
        return chunk
