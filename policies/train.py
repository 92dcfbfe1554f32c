"""`gloverec train`: behaviour cloning (or any policy type registered with LeRobot: ``policy_type``) on a recorded
dataset with LeRobot's policy factory, processors, optimiser presets and checkpoint layout, plus a train/validation
split by episode and a loss curve.

    OUT/checkpoints/000500/pretrained_model/   config.json, model.safetensors, train_config.json,
                                               policy_preprocessor*.json|safetensors, policy_postprocessor*,
                                               gloverec.json (dataset, fps, robot, task, feature names)
    OUT/checkpoints/000500/training_state/     optimiser, scheduler, RNG and step (lerobot's)
    OUT/checkpoints/000500/loss_history.json
    OUT/checkpoints/last -> 000500
    OUT/loss_curve.png  OUT/split.json  OUT/train_summary.json

``also``: more datasets trained on with the first (the same robot, rate and policy inputs; other features may
differ, so plain demonstrations and takeover recordings train together): each split by episode the same way, their
frames drawn together, a takeover recording's by who drove them (policies/data.py FrameCache.weights).
Normalisation statistics come from the training episodes only. ``learn_from`` intended: the action chunks learnt
are the wearer's (``expert.action``: a DART recording's before its noise, a takeover recording's where the policy
drove; recorder/record/dart.py), a plain demonstration's its executed ones.
The frames are decoded once into a frame cache, in memory or, for a dataset bigger than memory, on disk beside it
(``frame_cache``; policies/diskcache.py): the same batches either way.
``resume`` continues from checkpoints/last with the same split, weights, optimiser, scheduler and RNG state: N steps
then N more equal 2N in one go.
"""

from __future__ import annotations

import contextlib
import dataclasses
import io
import json
import shutil
import signal
import sys
import threading
import time
import traceback
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

from policies import diskcache, inputs as named_inputs
from policies.bc import POLICY_TYPE  # importing policies.bc registers gloverec_bc
from policies.config import TrainConfig
from policies.data import DatasetRef, FrameCache, decoded_bytes, load_meta, recorded_with, resolve, split_episodes
from recorder import GloverecError, one_line
from recorder.plugins import load_plugins
from recorder.record.dart import EXPERT_ACTION
from recorder.video_backend import video_backend

SHORT_NAMES = {"bc": POLICY_TYPE}  # `--policy bc`, the default
FLAGS = {"optimizer_lr": "--lr", "inputs": "--inputs"}  # the policy config fields these flags set


def policy_type(name: str) -> str:
    """The LeRobot policy type ``--policy NAME`` names: ``bc`` (gloverec_bc) or any type registered with
    ``PreTrainedConfig.register_subclass``, LeRobot's own or a plugin module's (recorder/plugins.py: loaded first, so
    that a module named in $GLOVEREC_PLUGINS can add one); an unknown name is one line listing the known ones."""
    load_plugins()
    known = PreTrainedConfig.get_known_choices()
    kind = SHORT_NAMES.get(name, name)
    if kind not in known:
        raise GloverecError(f"unknown policy {name!r}; known: bc ({POLICY_TYPE}), {', '.join(sorted(known))}")
    return kind


ACTION_FROM = {"executed": "action", "intended": EXPERT_ACTION}  # TrainConfig.learn_from: the feature learnt


def _say(text: str) -> None:
    print(text, file=sys.stderr, flush=True)


def _policy_config(policy: str, cfg: TrainConfig, features: dict):
    """The policy's LeRobot config from the train config; named inputs (``--inputs``) the dataset (info.json
    ``features``) lacks are one line."""
    extra = dict(cfg.policy)
    if cfg.lr is not None:
        extra["optimizer_lr"] = cfg.lr
    if cfg.inputs is not None:
        try:
            extra["inputs"] = list(named_inputs.parse(cfg.inputs))
        except ValueError as exc:
            raise GloverecError(f"--inputs: {exc}") from None
        lacking = named_inputs.missing(tuple(extra["inputs"]), features)
        if lacking:
            raise GloverecError(f"--inputs {cfg.inputs}: the dataset has no {lacking[0]}")
    config_cls = PreTrainedConfig.get_choice_class(policy)
    known = {f.name for f in dataclasses.fields(config_cls)}
    unknown = sorted(set(extra) - known)
    if unknown:  # the flags that set a field by name say so
        named = [f"{k} ({FLAGS[k]})" if k in FLAGS else k for k in unknown]
        raise GloverecError(f"unknown {policy} policy setting(s) {', '.join(named)}")
    try:
        return config_cls(device="cpu", push_to_hub=False, **extra)
    except (TypeError, ValueError) as exc:
        what = f"bad {policy} policy setting" if extra else f"the {policy} policy's config does not build"
        raise GloverecError(f"{what}: {one_line(exc)}") from None


def train(
    ref: DatasetRef,
    out: str | Path,
    cfg: TrainConfig,
    policy: str = "bc",
    resume: bool = False,
    progress: bool = True,
    also: tuple[DatasetRef, ...] = (),
) -> dict:
    """Train (or resume) a policy on ``ref`` (and the datasets ``also``); returns the summary also written to
    OUT/train_summary.json."""
    kind = policy_type(policy)
    out = Path(out)
    last = out / "checkpoints" / "last"  # lerobot's CHECKPOINTS_DIR / LAST_CHECKPOINT_LINK
    if resume and not last.exists():
        raise GloverecError(f"nothing to resume in {out}: it has no checkpoints/last")
    if not resume and out.exists() and (not out.is_dir() or any(out.iterdir())):
        raise GloverecError(f"{out} already exists: pass --resume to continue its training, or choose another --out")

    t0 = time.perf_counter()
    meta = load_meta(ref)
    metas = {a: load_meta(a) for a in also}
    history: list[dict] = []
    if resume:
        last = last.resolve()
        pretrained = last / PRETRAINED_MODEL_DIR
        split = json.loads((out / "split.json").read_text())
        if split["dataset"]["repo_id"] != ref.repo_id:
            raise GloverecError(f"{out} was trained on {split['dataset']['repo_id']}, not {ref.repo_id}")
        train_eps, val_eps = split["train"], split["validation"]
        learnt = split.get("learn_from", "executed")
        if learnt != cfg.learn_from:
            raise GloverecError(f"{out} learns the {learnt} actions: resume it with --learn-from {learnt}")
        also = tuple(resolve(a["repo_id"], root=a["root"]) for a in split.get("also", []))
        metas = {a: load_meta(a) for a in also}
        splits = [(a, t, v) for a, t, v in zip(also, split.get("also_train", []), split.get("also_validation", []))]
        policy_cfg = PreTrainedConfig.from_pretrained(pretrained)
        policy_cfg.pretrained_path = pretrained
        history = json.loads((last / "loss_history.json").read_text())
        set_seed(cfg.seed)
    else:
        policy_cfg = _policy_config(kind, cfg, meta.features)
        if hasattr(policy_cfg, "set_instructions"):
            trained = {str(t) for m in (meta, *metas.values()) for t in m.tasks.index}
            policy_cfg.set_instructions(trained, named_inputs.task_instructions(ref.root))
        train_eps, val_eps = split_episodes(meta, ref.root, cfg.val_fraction, cfg.seed, cfg.successful_only)
        splits = [(a, *split_episodes(metas[a], a.root, cfg.val_fraction, cfg.seed, cfg.successful_only))
                  for a in also]  # fmt: skip
        set_seed(cfg.seed)
    # the wearer's intended action: a plain demonstration's is the executed one (no noise, no policy drove), so it
    # trains beside DART and DAgger recordings; at least one dataset must hold expert.action, or the flag is a mistake
    wanted = ACTION_FROM[cfg.learn_from]
    learnt = {r: wanted if wanted in m.features else "action" for r, m in [(ref, meta), *((a, metas[a]) for a in also)]}
    if wanted not in learnt.values():
        raise GloverecError(f"--learn-from {cfg.learn_from}: no dataset has {wanted} (record one with gloverec record "
                            "--dart SCALE, or a takeover recording with --policy DIR)")  # fmt: skip
    try:  # a type this trainer cannot drive (its class, its processors or an optional dependency missing): one line
        with contextlib.redirect_stdout(io.StringIO()):  # lerobot prints "Loading weights from local directory"
            policy_obj = make_policy(policy_cfg, ds_meta=meta)
    except (ValueError, TypeError, ImportError, NotImplementedError) as exc:
        raise GloverecError(f"cannot make a {policy_cfg.type} policy: {one_line(exc)}") from None
    keys = [*policy_obj.config.input_features, "action"]
    if getattr(policy_obj.config, "reads_task", False):
        keys.append("task")
    delta = history_deltas(resolve_delta_timestamps(policy_obj.config, meta), keys)
    for a, _, _ in splits:
        _check_alike(meta, ref, metas[a], a, keys)
    _say(f"inputs: {describe_inputs(policy_obj.config)}")
    sets = [(ref, train_eps, val_eps), *splits]
    all_metas = {ref: meta, **metas}
    needed = sum(decoded_bytes(all_metas[r], [*t, *v], keys, delta) for r, t, v in sets)
    store, why = diskcache.choose(cfg.frame_cache, needed, diskcache.memory_available())
    _say(f"frame cache {'on disk, beside the dataset' if store == 'disk' else 'in memory'}: {why}")
    train_caches, val_caches = [], []
    for r, t, v in sets:
        _say(f"loading {r.repo_id} ({r.root}): {len(t)} training and {len(v)} validation episodes")
        train_caches.append(FrameCache(r, t, keys, delta, progress, learnt[r], store))
        val_caches.append(FrameCache(r, v, keys, delta, progress, learnt[r], store))
    train_cache, val_cache = FrameCache.join(train_caches), FrameCache.join(val_caches)
    # the policy's frames of a takeover recording teach its mistakes when the label is what it did, and what the
    # wearer would have done there when it is the wearer's (DAgger): learnt from the intended action, they count
    weights = train_cache.weights(cfg.intervention_weight, cfg.policy_frames or cfg.learn_from == "intended")
    if resume:
        pre, post = make_pre_post_processors(policy_obj.config, pretrained_path=str(pretrained))
    else:
        stats = train_cache.stats(keys, meta.stats or {})
        try:
            pre, post = make_pre_post_processors(policy_obj.config, dataset_stats=stats)
        except (ValueError, ImportError) as exc:  # "Processor for policy type 'x' is not implemented."
            raise GloverecError(f"cannot train a {policy_obj.config.type} policy: {one_line(exc)}") from None
        if hasattr(policy_obj, "adopt_stats"):
            policy_obj.adopt_stats(stats)
        _check_forward(policy_obj, pre, train_cache)
        out.mkdir(parents=True, exist_ok=True)
        (out / "split.json").write_text(
            json.dumps(
                {
                    "dataset": ref.as_dict(),
                    "seed": cfg.seed,
                    "successful_only": cfg.successful_only,
                    "learn_from": cfg.learn_from,
                    "train": train_eps,
                    "validation": val_eps,
                    "also": [a.as_dict() for a, _, _ in splits],
                    "also_train": [t for _, t, _ in splits],
                    "also_validation": [v for _, _, v in splits],
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
    extras["also"] = [a.as_dict() for a, _, _ in splits]
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
        with StopRequest() as stop:
            _loop(bar, train_cache, val_cache, pre, post, policy_obj, optimizer, scheduler, tcfg, cfg, val_every,
                  history, extras, out, weights, stop)  # fmt: skip
    except KeyboardInterrupt:
        bar.close()
        kept = out / CHECKPOINTS_DIR / LAST_CHECKPOINT_LINK
        if kept.exists():
            saved = int(kept.resolve().name)  # the step under way when asked to stop, or an earlier one's
            _say(f"interrupted at step {max(bar.n, saved)} (checkpoint: step {saved}); the same command with "
                 "--resume continues from there")  # fmt: skip
        elif not resume:  # nothing trained yet: what this run wrote goes, so the same command starts afresh
            shutil.rmtree(out, ignore_errors=True)
            _say(f"interrupted before the first step: nothing kept in {out}; the same command starts afresh")
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
        "learn_from": cfg.learn_from,
        "also": [a.as_dict() for a, _, _ in splits],
        "train_episodes": len(train_cache.episodes),
        "val_episodes": len(val_cache.episodes),
        "frames_by_wearer": int((train_cache.driver == 1).sum()),
        "frames_by_policy": int((train_cache.driver == 2).sum()),
        "inputs": describe_inputs(policy_obj.config),
        "train_frames": n,
        "val_frames": len(val_cache),
        "final_train_loss": final.get("train_loss"),
        "final_val_loss": final.get("val_loss"),
        "loss_curve": str(out / "loss_curve.png"),
        "wall_s": round(time.perf_counter() - t0, 1),
    }
    (out / "train_summary.json").write_text(json.dumps(summary, indent=1))
    return summary


class StopRequest:
    """Ctrl-C (SIGINT) or `kill` (SIGTERM) while training: the first ends the run after the step under way, with a
    checkpoint of it (so that --resume continues from there, whatever the save interval), a second at once. Outside
    the main thread (where no handler can be set) both act at once, as before."""

    SIGNALS = (signal.SIGINT, signal.SIGTERM)

    def __init__(self):
        self.requested = False
        self._old: dict = {}

    def __enter__(self) -> StopRequest:
        if threading.current_thread() is threading.main_thread():
            self._old = {s: signal.signal(s, self._handle) for s in self.SIGNALS}
        return self

    def _handle(self, *_) -> None:
        if self.requested:
            raise KeyboardInterrupt
        self.requested = True

    def __exit__(self, *_) -> None:
        for s, handler in self._old.items():
            signal.signal(s, handler)


def _loop(bar, train_cache, val_cache, pre, post, policy_obj, optimizer, scheduler, tcfg, cfg, val_every, history,
          extras, out, weights=None, stop: StopRequest | None = None) -> None:  # fmt: skip
    """The training steps from the bar's position to cfg.steps: validation, history and checkpoints. ``weights``:
    how often to draw each training frame (None: uniformly). ``stop`` asked: a checkpoint of the step just done, then
    KeyboardInterrupt."""

    n = len(train_cache)
    running: list[float] = []
    for step in bar:
        if weights is None:
            picked = torch.randint(n, (cfg.batch_size,))
        else:
            picked = torch.multinomial(weights, cfg.batch_size, replacement=True)
        batch = pre(train_cache.batch(picked))
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
        if done % tcfg.save_freq == 0 or done == cfg.steps or (stop is not None and stop.requested):
            _save(out, done, tcfg, policy_obj, optimizer, scheduler, pre, post, history, extras)
        if stop is not None and stop.requested:
            raise KeyboardInterrupt


def history_deltas(delta: dict | None, keys: list[str]) -> dict | None:
    """LeRobot's delta timestamps for the features the policy reads: a history window (observation deltas) for
    the vectors only, cameras at the newest frame (the policy reads no camera history, and decoding it would cost
    a video frame per step of the window)."""
    if not delta:
        return delta
    kept = {k: v for k, v in delta.items() if k in keys and not k.startswith("observation.images.")}
    return kept or None


def _check_forward(policy, pre, cache: FrameCache) -> None:
    """One forward pass on two training frames before anything is written, as validation does it (eval mode, no
    gradient, the RNG put back: training goes on as without it). A type whose forward wants what this trainer does not
    give (a reinforcement-learning policy's rewards, frame indices) or returns no (loss, info) is one line."""
    kind = policy.config.type
    policy.eval()
    try:
        with torch.random.fork_rng(), torch.no_grad():
            result = policy.forward(pre(cache.batch(torch.arange(min(2, len(cache))))))
    except Exception as exc:  # noqa: BLE001  (whatever the type raises: where, and one line)
        where = traceback.extract_tb(exc.__traceback__)[-1]
        raise GloverecError(f"cannot train a {kind} policy: its forward on a batch of "
                            f"{', '.join(cache.data)} raised {type(exc).__name__}: {one_line(exc)} "
                            f"({Path(where.filename).name}:{where.lineno})") from None  # fmt: skip
    finally:
        policy.train()
    if not (isinstance(result, tuple) and torch.is_tensor(result[0]) and result[0].ndim == 0):
        raise GloverecError(f"cannot train a {kind} policy: its forward returns no (loss, info)")


def _check_alike(meta, ref: DatasetRef, other, other_ref: DatasetRef, keys: list[str]) -> None:
    """One line when ``other`` cannot train with ``ref``: another rate, or a policy input or the action missing or
    shaped or named otherwise."""
    task, other_task = (recorded_with(r.root).get("env_task") for r in (ref, other_ref))
    if task and other_task and task != other_task:
        raise GloverecError(f"the task differs between {ref.repo_id} and {other_ref.repo_id} ({task}, {other_task}): "
                            "train them apart")  # fmt: skip
    if other.fps != meta.fps:
        raise GloverecError(f"{other_ref.repo_id} is recorded at {other.fps} fps, {ref.repo_id} at {meta.fps}: "
                            "train them apart")  # fmt: skip
    for key in keys:
        if key == "task":  # every dataset has one; unseen instructions are in the policy's vocabulary
            continue
        mine, theirs = meta.features.get(key), other.features.get(key)
        if theirs is None:
            raise GloverecError(f"{other_ref.repo_id} has no {key}, which the policy reads in {ref.repo_id}")
        if tuple(mine["shape"]) != tuple(theirs["shape"]) or mine.get("names") != theirs.get("names"):
            raise GloverecError(f"{key} differs between {ref.repo_id} and {other_ref.repo_id} (shape or names): "
                                "another robot or task?")  # fmt: skip


def describe_inputs(cfg) -> str:
    """What a policy reads, for people: "observation.state (40 of 53 elements), observation.images.front, task
    (4 instructions)"."""
    parts, idx = [], getattr(cfg, "state_indices", None)
    for key, ft in cfg.input_features.items():
        parts.append(f"{key} ({len(idx)} of {ft.shape[0]} elements)" if key == "observation.state" and idx else key)
    if getattr(cfg, "reads_task", False):
        parts.append(
            f"task ({len(cfg.trained_instructions or cfg.instructions)} of the task's {len(cfg.instructions)} "
            "instructions)"
        )
    elif "task" in (getattr(cfg, "inputs", None) or ()):  # asked for, and left out: say why, not silently
        parts.append("not the task: every training episode has the same instruction, which tells the policy nothing")
    return ", ".join(parts)


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
    first = recorded_with(ref.root)
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
    import matplotlib.pyplot as plt  # only for the loss plot: not at start-up

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
