"""Where a policy checkpoint is, found without torch or LeRobot: a command given a folder that holds no policy
says so in a fraction of a second, before those load (seconds)."""

from __future__ import annotations

from pathlib import Path

from recorder import GloverecError

BASELINES = ("demonstrator", "random", "fist")  # `gloverec eval --policy NAME`'s agents that are no checkpoint


def find_pretrained(path: str | Path) -> Path:
    """The pretrained_model folder of ``path``: itself, PATH/pretrained_model or PATH/checkpoints/last/..."""
    p = Path(path)
    for c in (p, p / "pretrained_model", p / "checkpoints" / "last" / "pretrained_model"):
        if (c / "config.json").is_file() and (c / "model.safetensors").is_file():
            return c.resolve()  # checkpoints/last moves on as training goes on: report the step's folder
    raise GloverecError(
        f"{path} holds no LeRobot policy (config.json + model.safetensors): give a "
        "pretrained_model folder, a checkpoint folder or a training output folder"
    )
