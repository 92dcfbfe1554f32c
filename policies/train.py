"""`gloverec train`: behaviour cloning on a recorded dataset with LeRobot's policy factory, processors,
optimiser presets and checkpoint layout, plus a train/validation split by episode and a loss curve.

    OUT/checkpoints/000500/pretrained_model/   config.json, model.safetensors, train_config.json,
                                               policy_preprocessor*.json|safetensors, policy_postprocessor*,
                                               gloverec.json (dataset, fps, robot, task, feature names)
    OUT/checkpoints/000500/training_state/     optimiser, scheduler, RNG and step (lerobot's)
    OUT/checkpoints/000500/loss_history.json
    OUT/checkpoints/last -> 000500
    OUT/loss_curve.png  OUT/split.json  OUT/train_summary.json

Normalisation statistics come from the training episodes only. ``resume`` continues from checkpoints/last
with the same split, weights, optimiser, scheduler and RNG state: N steps then N more equal 2N in one go.
"""

from __future__ import annotations

import contextlib
import dataclasses
import io
import json
import sys
import time
from pathlib import Path

import numpy as np
import torch
from lerobot.common.train_utils import (
    get_step_checkpoint_dir,
    load_training_state,
    save_checkpoint,
    update_last_checkpoint,
)
from lerobot.configs.default import DatasetConfig
from lerobot.configs.policies import PreTrainedConfig
from lerobot.configs.train import TrainPipelineConfig
from lerobot.datasets.factory import resolve_delta_timestamps
from lerobot.optim.factory import make_optimizer_and_scheduler
from lerobot.policies.factory import make_policy, make_pre_post_processors
from lerobot.utils.constants import CHECKPOINTS_DIR, LAST_CHECKPOINT_LINK, PRETRAINED_MODEL_DIR
from lerobot.utils.random_utils import set_seed
from tqdm import tqdm

import policies.bc  # noqa: F401  (registers gloverec_bc)
from policies.config import TrainConfig
from policies.data import DatasetRef, FrameCache, load_meta, sidecar, split_episodes
from recorder import GloverecError
from recorder.video_backend import video_backend

POLICY_TYPES = {"bc": "gloverec_bc"}


def _say(text: str) -> None:
    print(text, file=sys.stderr, flush=True)


def _policy_config(policy: str, cfg: TrainConfig):

    extra = dict(cfg.policy)
    if cfg.lr is not None:
        extra["optimizer_lr"] = cfg.lr
    config_cls = PreTrainedConfig.get_choice_class(POLICY_TYPES[policy])
    known = {f.name for f in dataclasses.fields(config_cls)}
    unknown = sorted(set(extra) - known)
    if unknown:
        raise GloverecError(f"unknown {policy} policy setting(s) {', '.join(unknown)}")
    try:
        return config_cls(device="cpu", push_to_hub=False, **extra)
    except (TypeError, ValueError) as exc:
        raise GloverecError(f"bad {policy} policy setting: {exc}") from None


def train(
    ref: DatasetRef, out: str | Path, cfg: TrainConfig, policy: str = "bc", resume: bool = False, progress: bool = True
) -> dict:
    """Train (or resume) a policy on ``ref``; returns the summary also written to OUT/train_summary.json."""
    if policy not in POLICY_TYPES:
        raise GloverecError(f"unknown policy {policy!r}; valid: {', '.join(POLICY_TYPES)}")
    out = Path(out)
    last = out / "checkpoints" / "last"  # lerobot's CHECKPOINTS_DIR / LAST_CHECKPOINT_LINK
    if resume and not last.exists():
        raise GloverecError(f"nothing to resume in {out}: it has no checkpoints/last")
    if not resume and out.exists() and (not out.is_dir() or any(out.iterdir())):
        raise GloverecError(f"{out} already exists: pass --resume to continue its training, or choose another --out")

    t0 = time.perf_counter()
    meta = load_meta(ref)
    history: list[dict] = []
    if resume:
        last = last.resolve()
        pretrained = last / PRETRAINED_MODEL_DIR
        split = json.loads((out / "split.json").read_text())
        if split["dataset"]["repo_id"] != ref.repo_id:
            raise GloverecError(f"{out} was trained on {split['dataset']['repo_id']}, not {ref.repo_id}")
        train_eps, val_eps = split["train"], split["validation"]
        policy_cfg = PreTrainedConfig.from_pretrained(pretrained)
        policy_cfg.pretrained_path = pretrained
        history = json.loads((last / "loss_history.json").read_text())
        set_seed(cfg.seed)
    else:
        policy_cfg = _policy_config(policy, cfg)
        train_eps, val_eps = split_episodes(meta, ref.root, cfg.val_fraction, cfg.seed, cfg.successful_only)
        set_seed(cfg.seed)
    with contextlib.redirect_stdout(io.StringIO()):  # lerobot prints "Loading weights from local directory"
        policy_obj = make_policy(policy_cfg, ds_meta=meta)
    keys = [*policy_obj.config.input_features, "action"]
    delta = resolve_delta_timestamps(policy_obj.config, meta)
    _say(f"loading {ref.repo_id} ({ref.root}): {len(train_eps)} training and {len(val_eps)} validation episodes")
    train_cache = FrameCache(ref, train_eps, keys, delta, progress)
    val_cache = FrameCache(ref, val_eps, keys, delta, progress)
    if resume:
        pre, post = make_pre_post_processors(policy_obj.config, pretrained_path=str(pretrained))
    else:
        stats = train_cache.stats(keys, meta.stats or {})
        pre, post = make_pre_post_processors(policy_obj.config, dataset_stats=stats)
        if hasattr(policy_obj, "adopt_stats"):
            policy_obj.adopt_stats(stats)
        out.mkdir(parents=True, exist_ok=True)
        (out / "split.json").write_text(
            json.dumps(
                {
                    "dataset": ref.as_dict(),
                    "seed": cfg.seed,
                    "successful_only": cfg.successful_only,
                    "train": train_eps,
                    "validation": val_eps,
                },
                indent=1,
            )
        )

    val_every = cfg.val_every or max(1, cfg.steps // 20)
    tcfg = TrainPipelineConfig(
        dataset=DatasetConfig(
            repo_id=ref.repo_id, root=str(ref.root), episodes=train_eps, video_backend=video_backend()
        ),
        policy=policy_obj.config,
        output_dir=out,
        job_name=f"gloverec_{policy}",
        resume=resume,
        seed=cfg.seed,
        num_workers=0,
        batch_size=cfg.batch_size,
        steps=cfg.steps,
        log_freq=val_every,
        save_freq=cfg.save_every or cfg.steps,
        optimizer=policy_obj.config.get_optimizer_preset(),
        scheduler=policy_obj.config.get_scheduler_preset(),
    )
    optimizer, scheduler = make_optimizer_and_scheduler(tcfg, policy_obj)
    start = 0
    if resume:
        start, optimizer, scheduler = load_training_state(last, optimizer, scheduler)
        _say(f"resuming {out} at step {start} of {cfg.steps}")
        if start >= cfg.steps:
            _say(f"already trained to step {start}: pass a larger --steps to train on")

    extras = _checkpoint_extras(ref, meta)
    n = len(train_cache)
    policy_obj.train()
    bar = tqdm(
        range(start, cfg.steps),
        initial=start,
        total=cfg.steps,
        desc="training",
        unit="step",
        disable=not progress,
        file=sys.stderr,
    )
    try:
        _loop(
            bar,
            train_cache,
            val_cache,
            pre,
            post,
            policy_obj,
            optimizer,
            scheduler,
            tcfg,
            cfg,
            val_every,
            history,
            extras,
            out,
        )
    except KeyboardInterrupt:
        bar.close()
        kept = out / CHECKPOINTS_DIR / LAST_CHECKPOINT_LINK
        where = f"last checkpoint: step {int(kept.resolve().name)}" if kept.exists() else "no checkpoint yet"
        _say(f"interrupted at step {bar.n} ({where}); the same command with --resume continues from there")
        raise
    bar.close()

    pretrained = (out / CHECKPOINTS_DIR / LAST_CHECKPOINT_LINK).resolve() / PRETRAINED_MODEL_DIR
    final = history[-1] if history else {}
    summary = {
        "out": str(out),
        "policy": str(pretrained),
        "policy_type": policy_obj.config.type,
        "dataset": ref.as_dict(),
        "steps": cfg.steps,
        "start_step": start,
        "batch_size": cfg.batch_size,
        "train_episodes": len(train_eps),
        "val_episodes": len(val_eps),
        "train_frames": n,
        "val_frames": len(val_cache),
        "final_train_loss": final.get("train_loss"),
        "final_val_loss": final.get("val_loss"),
        "loss_curve": str(out / "loss_curve.png"),
        "wall_s": round(time.perf_counter() - t0, 1),
    }
    (out / "train_summary.json").write_text(json.dumps(summary, indent=1))
    return summary


def _loop(
    bar, train_cache, val_cache, pre, post, policy_obj, optimizer, scheduler, tcfg, cfg, val_every, history, extras, out
) -> None:
    """The training steps from the bar's position to cfg.steps: validation, history and checkpoints."""

    n = len(train_cache)
    running: list[float] = []
    for step in bar:
        batch = pre(train_cache.batch(torch.randint(n, (cfg.batch_size,))))
        loss, _ = policy_obj.forward(batch)
        optimizer.zero_grad(set_to_none=True)
        loss.backward()
        torch.nn.utils.clip_grad_norm_(policy_obj.parameters(), tcfg.optimizer.grad_clip_norm)
        optimizer.step()
        if scheduler is not None:
            scheduler.step()
        running.append(loss.item())
        done = step + 1
        if done % val_every == 0 or done == cfg.steps:
            val = _validation_loss(policy_obj, pre, val_cache, cfg.batch_size)
            history.append(
                {
                    "step": done,
                    "train_loss": float(np.mean(running)),
                    "val_loss": val,
                    "lr": optimizer.param_groups[0]["lr"],
                }
            )
            running = []
            bar.set_postfix(train=f"{history[-1]['train_loss']:.4f}", val="-" if val is None else f"{val:.4f}")
        if done % tcfg.save_freq == 0 or done == cfg.steps:
            _save(out, done, tcfg, policy_obj, optimizer, scheduler, pre, post, history, extras)


def _validation_loss(policy, pre, cache: FrameCache, batch_size: int) -> float | None:

    if len(cache) == 0:
        return None
    policy.eval()
    total, count = 0.0, 0
    with torch.no_grad():
        for i in range(0, len(cache), batch_size):
            idx = torch.arange(i, min(i + batch_size, len(cache)))
            loss, _ = policy.forward(pre(cache.batch(idx)))
            total += loss.item() * len(idx)
            count += len(idx)
    policy.train()
    return total / count


def _checkpoint_extras(ref: DatasetRef, meta) -> dict:
    """gloverec.json: what `gloverec eval` needs to rebuild the environment and check it matches."""
    side = sidecar(ref.root)
    first = side[min(side)] if side else {}
    return {
        "dataset": ref.as_dict(),
        "fps": meta.fps,
        "robot": meta.robot_type or first.get("robot"),
        "task": first.get("env_task"),
        "names": {k: v.get("names") for k, v in meta.features.items() if k.startswith("observation.") or k == "action"},
    }


def _save(out: Path, step: int, tcfg, policy, optimizer, scheduler, pre, post, history, extras) -> None:

    ckpt = get_step_checkpoint_dir(out, tcfg.steps, step)
    save_checkpoint(ckpt, step, tcfg, policy, optimizer, scheduler, pre, post)
    (ckpt / PRETRAINED_MODEL_DIR / "gloverec.json").write_text(json.dumps(extras, indent=1))
    (ckpt / "loss_history.json").write_text(json.dumps(history))
    update_last_checkpoint(ckpt)  # only now: an interrupted save leaves `last` on the previous checkpoint
    plot_losses(history, out / "loss_curve.png", title=f"{tcfg.policy.type} on {tcfg.dataset.repo_id}")


def plot_losses(history: list[dict], path: Path, title: str = "") -> None:
    import matplotlib  # the Agg backend must be chosen before pyplot loads: both here

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4), dpi=100)
    steps = [h["step"] for h in history]
    ax.plot(steps, [h["train_loss"] for h in history], label="train")
    val = [(h["step"], h["val_loss"]) for h in history if h.get("val_loss") is not None]
    if val:
        ax.plot(*zip(*val), label="validation (held-out episodes)")
    ax.set_yscale("log")
    ax.set_xlabel("step")
    ax.set_ylabel("L1 loss (normalised actions)")
    ax.set_title(title)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    fig.tight_layout()
    tmp = path.with_name(f".{path.name}.tmp.png")
    fig.savefig(tmp)
    plt.close(fig)
    tmp.replace(path)
