"""`gloverec replay`: execute an episode's recorded actions open loop and measure how far the replayed states
drift from the recorded ones.

The environment is reset with the episode's seed (our sidecar metadata) on its robot and task (sidecar, else
info.json's robot_type) at the dataset's fps; then action[k] is applied after comparing observation k. MuJoCo
is deterministic, so on the machine that recorded it the divergence is 0; anything else means the dataset, the
model files or the physics changed since (a different MuJoCo, an edited robot or task config).
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
from lerobot.datasets.lerobot_dataset import LeRobotDataset

from policies.data import DatasetRef, dataset_info, sidecar
from policies.dataref import recorded_options
from policies.evaluate import VIDEO_SIZE, _write_video, make_env
from recorder import GloverecError
from recorder.paths import video_file
from recorder.video_backend import video_backend

TOLERANCE = 1e-5  # float32 rounding; a replay within it reproduces the recording
COMPARED = ("observation.state", "observation.environment_state")


def replay(
    ref: DatasetRef, episode: int, video: str | Path | None = None, task: str | None = None, robot: str | None = None
) -> dict:
    info = dataset_info(ref.root)
    total = info.get("total_episodes", 0)
    if not 0 <= episode < total:
        have = f"it has {total}: 0..{total - 1}" if total else "it has none"
        raise GloverecError(f"{ref.repo_id} has no episode {episode} ({have})")
    meta = sidecar(ref.root).get(episode)
    if meta is not None and meta.get("seed") is None and (meta.get("trimmed_s") or [0])[0]:
        raise GloverecError(
            f"episode {episode} of {ref.repo_id} was trimmed at its start ({meta['trimmed_s'][0]:g} s, gloverec "
            "edit): a replay starts at the reset, which it no longer has; replay the original episode "
            f"({meta.get('edited_from', 'its source')} of the dataset it was edited from)"
        )
    if meta is None or meta.get("seed") is None:
        raise GloverecError(
            f"episode {episode} of {ref.repo_id} has no seed in {ref.root}/meta/gloverec "
            "(not recorded by gloverec): it cannot be replayed"
        )
    task = task or meta.get("env_task")
    robot = robot or meta.get("robot") or info.get("robot_type")
    if not task or not robot:
        missing = "task" if not task else "robot"
        raise GloverecError(f"episode {episode} of {ref.repo_id}: its metadata does not say its {missing}")
    fps = float(info.get("fps") or meta.get("fps") or 30)

    t0 = time.perf_counter()
    ds = LeRobotDataset(ref.repo_id, root=ref.root, episodes=[episode], video_backend=video_backend())
    rows = ds.hf_dataset  # the episode's rows, without decoding any video
    rows.set_format("torch", columns=[c for c in (*COMPARED, "action", "episode_index") if c in rows.column_names])
    frames = [rows[i] for i in range(len(rows))]
    if not frames or any(int(f["episode_index"]) != episode for f in frames):
        raise GloverecError(f"episode {episode} of {ref.repo_id} could not be read from {ref.root}")
    recorded = {k: np.stack([f[k].numpy() for f in frames]) for k in COMPARED if k in frames[0]}
    actions = np.stack([f["action"].numpy() for f in frames])

    options = {**recorded_options(info, meta, cameras=False), "control_hz": fps}  # a free wrist, a generated scene's
    env = make_env(task, robot, render_mode="rgb_array" if video else None, **options,
                   **({"image_size": VIDEO_SIZE} if video else {}))  # fmt: skip
    try:
        obs, _ = env.reset(seed=int(meta["seed"]))
        for k in recorded:
            if obs[k].shape != recorded[k].shape[1:]:
                raise GloverecError(
                    f"{k} differs: the dataset has shape {recorded[k].shape[1:]}, {task} on {robot} "
                    f"gives {obs[k].shape}"
                )
        replayed = {k: [] for k in recorded}
        film = [env.render()] if video else None
        success = False
        for a in actions:
            for k in recorded:
                replayed[k].append(obs[k])
            obs, _, _, _, step_info = env.step(a)
            success = bool(step_info["is_success"])
            if video:
                film.append(env.render())
    finally:
        env.close()

    out = {
        "repo_id": ref.repo_id,
        "root": str(ref.root),
        "episode": episode,
        "seed": int(meta["seed"]),
        "task": task,
        "robot": robot,
        "fps": fps,
        "frames": len(actions),
    }
    per_step_max = np.zeros(len(actions))
    for k in recorded:
        d = np.abs(np.stack(replayed[k]).astype(np.float64) - recorded[k].astype(np.float64))
        short = k.removeprefix("observation.")
        out[f"{short}_max_abs"] = float(d.max()) if d.size else 0.0
        out[f"{short}_mean_abs"] = float(d.mean()) if d.size else 0.0
        per_step_max = np.maximum(per_step_max, d.max(axis=1) if d.shape[1] else 0.0)
    over = np.flatnonzero(per_step_max > TOLERANCE)
    out.update(
        max_abs=float(per_step_max.max()) if len(per_step_max) else 0.0,
        max_abs_per_step=[float(x) for x in per_step_max],
        first_divergent_step=int(over[0]) if len(over) else None,
        reproduced=not len(over),
        recorded_success=meta.get("success"),
        replayed_success=success,
        wall_s=round(time.perf_counter() - t0, 2),
    )
    if video:
        out["video"] = str(_write_video(video_file(video, f"episode{episode:03d}_replay.mp4"), film, fps))
    return out
