"""`gloverec train`, `gloverec eval`, `gloverec generate` and `gloverec replay`: flags here, the work in
policies.train, .evaluate, .generate and .replay.

``add_parsers(subparsers)`` adds the three commands to the `gloverec` subparsers (recorder/cli.py); each
handler returns the exit code or raises GloverecError (one line, exit 1). With ``--json`` stdout carries
exactly one JSON object (everything else, lerobot's chatter included, goes to stderr). Heavy modules load inside
the handlers.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import logging
import sys
from pathlib import Path

from policies.checkpoint import BASELINES, find_pretrained
from policies.config import TrainConfig
from recorder import GloverecError, config, loading
from recorder.argtypes import natural, positive_int
from recorder.paths import HUB_ENV

HUB_HELP = f"the local hub folder (default: ${HUB_ENV}, else datasets/hub)"


def _dataset_flags(p: argparse.ArgumentParser) -> None:
    p.add_argument("--repo-id", required=True, help="dataset id, USER/NAME")
    where = p.add_mutually_exclusive_group()
    where.add_argument("--hub", help=HUB_HELP)
    where.add_argument("--root", help="a dataset folder instead of the hub (e.g. an unpushed recording)")
    p.add_argument("--version", help="the hub version, vN (default: the newest)")


def add_parsers(subparsers) -> None:
    t = subparsers.add_parser("train", help="train a policy (behaviour cloning unless --policy) on a recorded dataset")
    _dataset_flags(t)
    t.add_argument("--policy", default="bc", metavar="NAME",
                   help="the policy type to train: bc (gloverec_bc, the default) or any type registered with LeRobot's "
                   "PreTrainedConfig.register_subclass, LeRobot's (act, ...) or a module's named in $GLOVEREC_PLUGINS "
                   "(docs/policies.md, Adding a policy type)")  # fmt: skip
    t.add_argument("--out", required=True, help="output folder: checkpoints, loss curve, split, summary")
    t.add_argument("--also", nargs="+", default=[], metavar="DATASET",
                   help="train on these datasets too: hub ids USER/NAME[@vN] (in --hub's hub) or dataset folders, "
                   "e.g. takeover recordings (same robot, rate and policy inputs)")  # fmt: skip
    t.add_argument("--resume", action="store_true", help="continue from OUT/checkpoints/last")
    t.add_argument("--config", help="a train YAML file (keys: the fields of policies/config.py TrainConfig)")
    config.add_arguments(t, TrainConfig)
    t.add_argument(
        "--threads",
        type=positive_int,
        default=1,
        help="torch CPU threads (default 1: fastest for small MLPs, and safe on a busy machine)",
    )
    t.add_argument("--json", action="store_true", help="print one JSON object at the end")
    t.set_defaults(func=cmd_train)

    e = subparsers.add_parser("eval", help="evaluate a policy in the simulated task: success rate, returns, videos")
    e.add_argument(
        "--policy",
        required=True,
        help="a LeRobot checkpoint (pretrained_model, checkpoint or training output folder), "
        "or a baseline: 'demonstrator' (the scripted demonstrator), 'random' (random actions), 'fist' (the open hand, "
        "a fist from the task's scripted close phase on)",
    )
    e.add_argument("--task", help="a registered task: pose, grasp, ... (default: the policy's training task)")
    e.add_argument("--robot", help="a robot hand: glovehand, shadow, leap (default: the policy's training robot)")
    e.add_argument("--episodes", type=positive_int, default=50, help="episodes (default 50)")
    e.add_argument(
        "--seed",
        type=natural,
        help="seed of the first episode, then +1 each (default 100000, away from the recorder's seeds 0, 1, ...)",
    )
    e.add_argument("--video", metavar="DIR|FILE.mp4", help="film the first episodes: into this folder, one mp4 "
                   "each named with its seed and outcome, or the first episode into FILE.mp4")  # fmt: skip
    e.add_argument("--videos", type=natural, help="how many episodes to film (default 2 into a folder, 1 into a "
                   "FILE.mp4)")  # fmt: skip
    e.add_argument("--threads", type=positive_int, default=1, help="torch CPU threads (default 1)")
    e.add_argument("--workers", type=positive_int, default=1,
                   help="episodes in this many processes at once, one torch thread each (default 1); the same "
                   "per-seed results as one")  # fmt: skip
    e.add_argument("--perturb", type=_perturbations, default=(), metavar="WHAT,WHAT",
                   help="evaluate again under scene changes the demonstrations never showed: light, colour (the "
                   "task's objects), camera (moved 5 degrees), or all; reported beside the plain figure")  # fmt: skip
    e.add_argument("--json", action="store_true", help="print one JSON object (success_rate, episodes, ...)")
    e.set_defaults(func=cmd_eval)

    g = subparsers.add_parser("generate", help="generate many demonstrations in simulation from a few recorded ones "
                              "(object-centric segments moved to new scenes; only successes kept)")  # fmt: skip
    g.add_argument("--from", dest="source", required=True, metavar="DATASET",
                   help="the demonstrations: a recording folder, or USER/NAME[@vN] in the hub")  # fmt: skip
    g.add_argument("--hub", help=HUB_HELP)
    g.add_argument("--out", required=True, help="the new dataset's folder (must not exist)")
    g.add_argument("--repo-id", help="the new dataset's id (default: the source's with _generated)")
    g.add_argument("--episodes", type=positive_int, default=100, help="successful episodes to generate (default 100; "
                   "with --resume, the total the dataset should hold)")  # fmt: skip
    g.add_argument("--resume", action="store_true", help="add to --out, a generation cut short, until it holds "
                   "--episodes (on the seeds after its last; the same --from, --scene and --dart)")  # fmt: skip
    g.add_argument("--seeds", type=_seeds, default=(10000, None), metavar="FIRST[-LAST]",
                   help="the new scenes' seeds: from FIRST on, one per attempt (default 10000, away from the "
                   "recorder's 0, 1, ... and the evaluation's 100000 on); FIRST-LAST: only those")  # fmt: skip
    g.add_argument("--max-attempts", type=positive_int, help="stop after this many scenes (default 5 per episode)")
    g.add_argument("--scene", action="append", type=_scene_option, default=[], metavar="KEY=VALUE",
                   help="a task setting for the new scenes, e.g. placement_m=0.1 (wider than the source's) or "
                   "'shapes=[box]' (the task's config fields, docs/envs.md); repeatable")  # fmt: skip
    g.add_argument("--dart", type=float, default=0.0, metavar="SCALE",
                   help="DART noise on the executed actions, a share of each element's range (the generated "
                   "action kept as expert.action; default 0: none)")  # fmt: skip
    g.add_argument("--dart-time-s", type=float, default=0.2, help="the noise's correlation time (default 0.2 s)")
    g.add_argument("--json", action="store_true", help="print one JSON object at the end")
    g.set_defaults(func=cmd_generate)

    r = subparsers.add_parser("replay", help="replay an episode's actions open loop and measure state divergence")
    _dataset_flags(r)
    r.add_argument("--episode", type=natural, required=True, help="episode index")
    r.add_argument("--video", metavar="FILE.mp4|DIR", help="film the replay: into FILE.mp4, or into this folder "
                   "as episodeK_replay.mp4")  # fmt: skip
    r.add_argument("--json", action="store_true", help="print one JSON object")
    r.set_defaults(func=cmd_replay)


@contextlib.contextmanager
def _quiet_stdout(json_mode: bool):
    """With --json, stdout is the JSON object only: anything printed meanwhile goes to stderr."""
    if json_mode:
        with contextlib.redirect_stdout(sys.stderr):
            yield
    else:
        yield


@contextlib.contextmanager
def _setup(threads: int | None = None):
    """torch's CPU threads and the root logger's level (lerobot's INFO chatter off) for one command, put back
    after it: a command called in-process (a test, a notebook) leaves the caller's settings as they were."""
    import torch  # not at start-up: the commands that need it import it

    root, before = logging.getLogger(), (logging.getLogger().level, torch.get_num_threads())
    root.setLevel(logging.WARNING)
    if threads:
        torch.set_num_threads(threads)
    try:
        yield
    finally:
        root.setLevel(before[0])
        torch.set_num_threads(before[1])


def cmd_train(args: argparse.Namespace) -> int:
    from policies.dataref import resolve  # no torch: the datasets are checked before it loads

    cfg = TrainConfig.load(args.config, **config.overrides(args, TrainConfig))
    ref = resolve(args.repo_id, args.hub, args.root, args.version)
    also = tuple(_also(text, args.hub) for text in args.also)
    if args.resume and also:
        raise GloverecError("--resume trains on the datasets it started with: leave out --also")
    loading("LeRobot and torch")
    from policies.train import train  # torch and lerobot: not at start-up

    with _quiet_stdout(args.json), _setup(args.threads):
        summary = train(ref, args.out, cfg, policy=args.policy, resume=args.resume,
                        progress=sys.stderr.isatty() or not args.json, also=also)  # fmt: skip
    if args.json:
        print(json.dumps(summary))
    else:
        val = summary["final_val_loss"]
        span = (
            f"from step {summary['start_step']} to {summary['steps']}"
            if summary["start_step"]
            else f"for {summary['steps']} steps"
        )
        print(
            f"trained {summary['policy_type']} {span} on {summary['train_episodes']} episodes "
            f"of {ref.repo_id} in {summary['wall_s']:.0f} s: train loss {summary['final_train_loss']:.4f}, "
            f"validation loss {'-' if val is None else f'{val:.4f}'} ({summary['val_episodes']} held-out episodes)"
        )
        print(f"policy: {summary['policy']}")
        print(f"loss curve: {summary['loss_curve']}")
    return 0


def _also(text: str, hub: str | None):
    """An --also dataset: a folder holding one (its id: the one it was recorded as, from our sidecar, else the
    folder's last two names), else USER/NAME[@vN] in the hub."""
    from policies.dataref import recorded_with, resolve  # no torch

    folder = Path(text)
    if (folder / "meta" / "info.json").is_file():
        named = recorded_with(folder).get("repo_id") or f"{folder.absolute().parent.name}/{folder.name}"
        return resolve(named, root=folder)
    if folder.exists():
        raise GloverecError(f"--also {text}: not a LeRobot dataset (no meta/info.json)")
    repo_id, _, version = text.partition("@")
    return resolve(repo_id, hub, None, version or None)


def _perturbations(text: str) -> tuple[str, ...]:
    from envs.tasks.perturb import PERTURBATIONS  # no MuJoCo model: numpy and mujoco's module only

    names = PERTURBATIONS if text == "all" else tuple(dict.fromkeys(s.strip() for s in text.split(",") if s.strip()))
    bad = [n for n in names if n not in PERTURBATIONS]
    if bad or not names:
        raise argparse.ArgumentTypeError(f"unknown perturbation {bad[0] if bad else text!r}; valid: "
                                         f"{', '.join(PERTURBATIONS)}, all")  # fmt: skip
    return names


def cmd_eval(args: argparse.Namespace) -> int:
    from envs import check_names  # MuJoCo (0.2 s): not at start-up

    check_names(args.robot, args.task)  # at once, not after torch and lerobot have loaded
    if args.policy not in BASELINES:
        find_pretrained(args.policy)  # a folder without a checkpoint, likewise
    one_file = bool(args.video) and args.video.lower().endswith(".mp4")
    if one_file and (args.videos or 1) > 1:
        raise GloverecError(f"--video {args.video} is one file: it films one episode (pass a folder for "
                            f"--videos {args.videos})")  # fmt: skip
    args.videos = args.videos if args.videos is not None else (1 if one_file else 2)
    loading("LeRobot and MuJoCo")
    from policies import evaluate as ev  # torch, lerobot and mujoco: not at start-up

    seed = ev.EVAL_SEED if args.seed is None else args.seed
    with _quiet_stdout(args.json), _setup(args.threads):
        if args.policy in ev.BASELINES:
            if not args.task or not args.robot:
                raise GloverecError(f"--policy {args.policy} needs --task and --robot")
            result = ev.evaluate_baseline(args.policy, args.task, args.robot, args.episodes, seed, args.video,
                                          args.videos, sys.stderr.isatty(), args.workers, args.perturb)  # fmt: skip
        else:
            result = ev.evaluate_checkpoint(args.policy, args.task, args.robot, args.episodes, seed, args.video,
                                            args.videos, sys.stderr.isatty(), args.workers, args.perturb)  # fmt: skip
    if args.json:
        print(json.dumps(result))
    else:
        print(
            f"{result['agent']} on {result['task']} ({result['robot']}): success {result['successes']}/"
            f"{result['episodes']} = {100 * result['success_rate']:.0f} %, mean return {result['mean_return']:.3f}, "
            f"mean length {result['mean_length']:.1f} steps (seeds {result['seeds'][0]}..{result['seeds'][-1]})"
        )
        for name, r in result.get("perturbed", {}).items():
            print(f"  under {name}: success {r['successes']}/{r['episodes']} = {100 * r['success_rate']:.0f} %")
        for path in result["videos"]:
            print(f"video: {path}")
    return 0


def _seeds(text: str) -> tuple[int, int | None]:
    first, _, last = text.partition("-")
    try:
        a, b = int(first), (int(last) if last else None)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r}: expected FIRST or FIRST-LAST (non-negative integers)") from None
    if a < 0 or (b is not None and b < a):
        raise argparse.ArgumentTypeError(f"{text!r}: expected FIRST or FIRST-LAST with 0 <= FIRST <= LAST")
    return a, b


def _scene_option(text: str) -> tuple[str, object]:
    import yaml

    key, eq, value = text.partition("=")
    if not eq or not key.strip():
        raise argparse.ArgumentTypeError(f"{text!r}: expected KEY=VALUE, e.g. placement_m=0.1")
    try:
        parsed = yaml.safe_load(value)
    except yaml.YAMLError:
        raise argparse.ArgumentTypeError(f"{text!r}: its value is not a number, list or word") from None
    return key.strip(), tuple(parsed) if isinstance(parsed, list) else parsed


def cmd_generate(args: argparse.Namespace) -> int:
    from recorder.record.store import check_root

    ref = _also(args.source, args.hub)  # a missing or damaged dataset: one line, before LeRobot loads
    if Path(args.out).exists() and not args.resume:
        raise GloverecError(f"--out {args.out} already exists: choose another folder, or pass --resume to generate "
                            "more into it")  # fmt: skip
    check_root(args.out, resume=args.resume)
    repo_id = args.repo_id or f"{ref.repo_id}_generated"
    first, last = args.seeds
    attempts = args.max_attempts or (last - first + 1 if last is not None else None)
    if last is not None and args.max_attempts:
        attempts = min(args.max_attempts, last - first + 1)
    if not 0.0 <= args.dart < 1.0:
        raise GloverecError(f"--dart {args.dart:g}: expected a share of the action's range, 0 to below 1")
    loading("LeRobot and MuJoCo")
    from policies.generate import GenerateConfig, generate  # torch, lerobot and mujoco: not at start-up

    cfg = GenerateConfig(episodes=args.episodes, seed=first, max_attempts=attempts, scene=dict(args.scene),
                         dart=args.dart, dart_time_s=args.dart_time_s, resume=args.resume)  # fmt: skip
    with _quiet_stdout(args.json), _setup():
        out = generate(ref, args.out, repo_id, cfg, progress=sys.stderr.isatty() or not args.json)
    if args.json:
        print(json.dumps(out))
    else:
        print(
            f"generated {out['accepted']} episodes of {out['task']} on {out['robot']} from {len(out['sources'])} "
            f"of {ref.repo_id}: {out['accepted']}/{out['attempts']} scenes accepted "
            f"({100 * out['acceptance_rate']:.0f} %), {out['accepted_per_min']:.1f} per minute, into {out['root']}"
        )
        for why, n in sorted(out["rejected_because"].items(), key=lambda kv: -kv[1]):
            print(f"  rejected {n}: {why}")
    if out["accepted"] < out["wanted"]:
        raise GloverecError(f"only {out['accepted']} of the {out['wanted']} episodes were generated in "
                            f"{out['attempts']} scenes: pass more --seeds or --max-attempts, or --resume")  # fmt: skip
    return 0


def cmd_replay(args: argparse.Namespace) -> int:
    from policies.dataref import resolve  # no torch: the dataset is checked before it loads

    ref = resolve(args.repo_id, args.hub, args.root, args.version)
    loading("LeRobot and MuJoCo")
    from policies.replay import replay  # torch, lerobot and mujoco: not at start-up

    with _quiet_stdout(args.json), _setup():
        out = replay(ref, args.episode, args.video)
    if args.json:
        print(json.dumps(out))
    else:
        verdict = (
            "reproduced exactly"
            if out["max_abs"] == 0
            else "reproduced"
            if out["reproduced"]
            else f"DIVERGED from step {out['first_divergent_step']}"
        )
        print(
            f"episode {out['episode']} of {out['repo_id']} ({out['task']} on {out['robot']}, seed {out['seed']}, "
            f"{out['frames']} frames): {verdict}; state max |diff| {out['state_max_abs']:.3g}, mean "
            f"{out['state_mean_abs']:.3g}; environment state max {out.get('environment_state_max_abs', 0):.3g}; "
            f"success recorded {out['recorded_success']}, replayed {out['replayed_success']}"
        )
        if out.get("video"):
            print(f"video: {out['video']}")
    if not out["reproduced"]:
        raise GloverecError(
            f"the replay of episode {out['episode']} diverged from the recording at step "
            f"{out['first_divergent_step']} (max |diff| {out['max_abs']:.3g}): the dataset, the robot "
            "or task configs, or the simulator changed since it was recorded"
        )
    return 0
