"""`gloverec eval`: run a policy in a gloverec environment for N episodes with fixed seeds; success rate,
returns, episode lengths and videos.

Anything that acts is an *agent* (``reset(env, seed)``, ``act(obs) -> action``), so the same harness scores
a LeRobot checkpoint (``PolicyAgent``: our BC, ACT from lerobot-train, any type LeRobot's factory knows),
the scripted demonstrator the datasets were recorded with (``DemonstratorAgent``), uniform random actions
(``RandomAgent``) and a blind fist at the script's close phase (``FistAgent``): the metric is shown to fail and
to succeed with the same code, and a policy that looks is measured against one that does not.

An evaluation is an ``EvalJob`` (policy, task, robot, environment options), run in this process or, with
``worker_pool(N)``, in N spawned processes, each episode seeded alike (the same per-seed results); ``perturbed``
runs it again under scene changes (envs/tasks/perturb.py).

A checkpoint is checked against the environment before anything runs: every input the policy reads
(``observation.state``, ``observation.environment_state``, ``observation.images.*``) must be observed with the
same shape (and, when the training dataset's feature names are known, the same names), ``action`` must match the
action space, and every instruction the task can draw must be one the policy knows (``check_instructions``);
otherwise one GloverecError line says what differs.
"""

from __future__ import annotations

import contextlib
import io
import json
import logging
import multiprocessing
import sys
import time
from dataclasses import dataclass, field, replace
from fractions import Fraction
from pathlib import Path

import draccus
import numpy as np
import torch
from lerobot.configs.policies import PreTrainedConfig
from lerobot.configs.types import FeatureType
from lerobot.policies.factory import get_policy_class, make_pre_post_processors
from lerobot.utils.io_utils import write_video
from tqdm import tqdm

import envs
import policies.bc  # noqa: F401  (registers gloverec_bc)
from envs.robots import load_robot, robot_names
from envs.tasks import CAMERAS
from envs.tasks.base import BASE_POSITION, action_names
from policies.checkpoint import BASELINES as BASELINE_NAMES, find_pretrained
from policies.data import dataset_info, recorded_with, sidecar
from recorder import GloverecError
from recorder.demonstrator import make_demonstrator
from recorder.lerobot_names import gloverec_names
from recorder.paths import video_file
from recorder.plugins import PLUGINS_ENV, load_plugins
from recorder.retarget import Retargeter

EVAL_SEED = 100_000  # recordings use seeds 0, 1, ... by default: evaluation episodes are never training ones
VIDEO_SIZE = (384, 512)  # (H, W), multiples of 16 for the codec; of videos when the policy has no cameras of its own


# ---------------------------------------------------------------- agents


class PolicyAgent:
    """A LeRobot policy with its processors, acting on gloverec observations."""

    def __init__(self, policy, pre, post, path: Path, context: dict):
        self.policy, self.pre, self.post, self.path, self.context = policy, pre, post, Path(path), context
        cfg = policy.config
        self.type = cfg.type
        self.inputs = consumed_features(cfg)
        self.reads_task = bool(getattr(cfg, "reads_task", False))
        self.instruction: str | None = None
        self.name = f"{cfg.type} ({path})"

    def reset(self, env, seed: int) -> None:
        self.policy.reset()
        if self.reads_task:  # the episode's instruction, as the recorder stores it (check_instructions: known)
            self.instruction = env.unwrapped.instruction()

    def act(self, obs: dict) -> np.ndarray:

        batch = {} if self.instruction is None else {"task": self.instruction}
        for key in self.inputs:
            x = torch.from_numpy(np.ascontiguousarray(obs[key]))
            batch[key] = x.permute(2, 0, 1).float() / 255 if key.startswith("observation.images.") else x.float()
        with torch.inference_mode():
            action = self.post(self.policy.select_action(self.pre(batch)))
        return action.squeeze(0).cpu().numpy()


class DemonstratorAgent:
    """The recorder's scripted demonstrator, through the retargeter (what `gloverec record` demonstrates with the
    emulated glove, without the glove's sensor noise)."""

    def __init__(self, task: str, robot: str):

        self.demo = make_demonstrator(task)
        self.robot = robot
        self.name = f"scripted {task} demonstrator"
        self.retarget = None
        self.motion = None
        self.env = None

    def reset(self, env, seed: int) -> None:

        self.env = env.unwrapped
        if self.retarget is None:
            self.retarget = Retargeter.for_env(self.env)
        self.retarget.reset()
        self.motion = self.demo.plan(self.env, seed=seed)

    def act(self, obs: dict) -> np.ndarray:
        if self.env.steps:
            self.motion.watch(self.env)  # what the last step did
        block = self.motion.at([self.env.t])
        action, _ = self.retarget(block.angles[0], block.palm_quat[0], block.palm_pos[0])
        return action


class RandomAgent:
    """Uniformly random actions in the action space (seeded per episode)."""

    name = "random actions"

    def __init__(self, task: str | None = None, robot: str | None = None):
        pass

    def reset(self, env, seed: int) -> None:
        self.space = env.action_space
        self.space.seed(seed)

    def act(self, obs: dict) -> np.ndarray:
        return self.space.sample()


class FistAgent:
    """A baseline that sees nothing: the open hand of the grasp demonstrator until the task's scripted close phase
    (``schedule["close"]``), then a fist, whatever the object. Where the script's approach alone nearly succeeds
    (HandGrasp), this is the figure a policy that looks must beat."""

    def __init__(self, task: str | None = None, robot: str | None = None):
        from recorder.demonstrator.grasp import PREGRASP  # the recorder's postures, loaded when used
        from recorder.hand.gestures import GESTURES

        self.postures = (PREGRASP, GESTURES["fist"])
        self.name = "fist at the close phase"
        self.retarget, self.env = None, None

    def reset(self, env, seed: int) -> None:
        self.env = env.unwrapped
        if "close" not in (getattr(self.env, "schedule", None) or {}):
            raise GloverecError(f"--policy fist needs a task with a scripted close phase (grasp); {self.env.task_name} "
                                "has none")  # fmt: skip
        if self.retarget is None:
            self.retarget = Retargeter.for_env(self.env)
        self.retarget.reset()

    def act(self, obs: dict) -> np.ndarray:
        closed = self.env.t >= self.env.schedule["close"]
        return self.retarget(self.postures[int(closed)])[0]


BASELINES = dict(zip(BASELINE_NAMES, (DemonstratorAgent, RandomAgent, FistAgent), strict=True))


# ---------------------------------------------------------------- loading checkpoints


def policy_context(pretrained: Path) -> dict:
    """What the checkpoint says about its training data: fps, robot, task and feature names. From our
    gloverec.json, else from lerobot-train's train_config.json -> the dataset's info.json and sidecar. Names in the
    tasks' naming, whichever a gloverec_sim dataset was recorded with (recorder/lerobot_names.py)."""
    ours = pretrained / "gloverec.json"
    if ours.is_file():
        ctx = json.loads(ours.read_text())
        return {**ctx, "names": gloverec_names(ctx.get("names") or {})}
    ctx: dict = {"fps": None, "robot": None, "task": None, "names": {}}
    try:
        ds = json.loads((pretrained / "train_config.json").read_text())["dataset"]
        root = Path(ds["root"]) if ds.get("root") else None
    except (OSError, ValueError, KeyError, TypeError):
        return ctx
    if root is not None and (root / "meta" / "info.json").is_file():
        info = dataset_info(root)
        first = recorded_with(root)
        ctx.update(
            fps=info.get("fps"),
            robot=info.get("robot_type") or first.get("robot"),
            task=first.get("env_task"),
            dataset={"repo_id": ds.get("repo_id"), "root": str(root)},
            names=gloverec_names({k: v.get("names") for k, v in info.get("features", {}).items()}),
        )
    return ctx


def load_policy(path: str | Path, device: str = "cpu") -> PolicyAgent:
    """Any LeRobot checkpoint whose type LeRobot knows: built-in, ours (importing policies.bc registers it), or one
    a plugin module registers (recorder/plugins.py: $GLOVEREC_PLUGINS, loaded here first)."""

    pretrained = find_pretrained(path)
    try:
        kind = json.loads((pretrained / "config.json").read_text()).get("type")
    except ValueError as exc:
        raise GloverecError(f"{pretrained}/config.json is not JSON: {exc}") from None
    load_plugins()
    if kind not in PreTrainedConfig.get_known_choices():
        raise GloverecError(
            f"{pretrained} is a policy of type {kind!r}, which LeRobot does not know here "
            f"(known: {', '.join(sorted(PreTrainedConfig.get_known_choices()))}; a type of your own registers in a "
            f"module named in ${PLUGINS_ENV})"
        )
    try:
        cfg = PreTrainedConfig.from_pretrained(pretrained, cli_overrides=[f"--device={device}"])
        cfg.pretrained_path = pretrained
        with contextlib.redirect_stdout(io.StringIO()):  # lerobot prints "Loading weights from local directory"
            policy = get_policy_class(kind).from_pretrained(pretrained, config=cfg)
        steps = json.loads((pretrained / "policy_preprocessor.json").read_text()).get("steps", [])
        overrides = (
            {"device_processor": {"device": device}}
            if any(s.get("registry_name") == "device_processor" for s in steps)
            else {}
        )
        pre, post = make_pre_post_processors(cfg, pretrained_path=str(pretrained), preprocessor_overrides=overrides)
    except (OSError, ValueError, KeyError, draccus.utils.ParsingError) as exc:
        raise GloverecError(f"cannot load the policy in {pretrained}: {exc}") from None
    return PolicyAgent(policy, pre, post, pretrained, policy_context(pretrained))


# ---------------------------------------------------------------- features


def consumed_features(cfg) -> dict:
    """The inputs a LeRobot policy reads: observation.state, the environment state and the images.
    Other dataset features LeRobot lists as inputs (observation.glove: the human hand) are not read."""

    out = {}
    if cfg.robot_state_feature is not None:
        out["observation.state"] = cfg.robot_state_feature
    for key, ft in (cfg.input_features or {}).items():
        if ft.type in (FeatureType.ENV, FeatureType.VISUAL):
            out[key] = ft
    return out


def trained_setup(context: dict) -> tuple[str | None, str | None]:
    """(task, robot) a checkpoint was trained on, from its training dataset's metadata: our recordings' sidecar
    (``env_task``, ``robot``), or the robot_type lerobot-record stores for the LeRobot robot gloverec_sim,
    ``gloverec_sim:TASK:ROBOT`` (lerobot_robot_gloverec.dataset_robot_type). Unknown stays None (the command asks
    for --task / --robot); an older gloverec_sim dataset's robot is the one whose actuators are its action's names."""
    task, robot = context.get("task"), context.get("robot")
    kind, _, rest = str(robot or "").partition(":")
    if kind == "gloverec_sim" and rest:
        stored_task, _, robot = rest.partition(":")
        task = task or stored_task
    names = context.get("names") or {}
    if robot not in robot_names() and names.get("action"):
        acts = list(names["action"])
        robot = next((r for r in robot_names() if acts in _action_name_lists(r)), None)
    return task, robot


def _action_name_lists(robot: str) -> list[list[str]]:
    r = load_robot(robot)
    return [list(action_names(r, rot, pos)) for rot in (True, False) for pos in (False, True)]


def _state_includes_task(agent: PolicyAgent, task: str, robot: str) -> bool:
    """The policy was trained in LeRobot's layout, the task's state inside observation.state (gloverec_sim): its
    state names hold the task's environment-state names (as the task registry's environment declares them)."""
    names = (agent.context.get("names") or {}).get("observation.state") or []
    if "observation.environment_state" in agent.inputs or not names:
        return False
    env = make_env(task, robot)
    try:
        return bool(set(env.unwrapped.environment_state_names) & set(names))
    finally:
        env.close()


def env_options(agent: PolicyAgent, video: bool, task: str, robot: str) -> dict:
    """Environment options a policy needs: its control rate, its cameras at its image size, and where it reads
    the task's state."""
    opts = {"state_includes_task": True} if _state_includes_task(agent, task, robot) else {}
    acts = (agent.context.get("names") or {}).get("action") or []
    if BASE_POSITION[0] in acts:  # trained with a free wrist (a tracker's): its actions place the base
        opts["base_position"] = True
    if agent.context.get("fps"):
        opts["control_hz"] = float(agent.context["fps"])
    cams = [k.removeprefix("observation.images.") for k in agent.inputs if k.startswith("observation.images.")]
    if cams:
        bad = [c for c in cams if c not in CAMERAS]
        if bad:
            raise GloverecError(
                f"the policy reads observation.images.{bad[0]}, a camera the environments do not "
                f"have (they have {', '.join(CAMERAS)})"
            )
        shape = agent.inputs[f"observation.images.{cams[0]}"].shape
        opts.update(cameras=tuple(cams), image_size=(int(shape[1]), int(shape[2])))
        if video:
            opts["video_size"] = VIDEO_SIZE  # the videos at a size people can see, the policy's input as trained
    elif video:
        opts["image_size"] = VIDEO_SIZE
    return opts


def check_features(agent: PolicyAgent, env, task: str, robot: str) -> None:
    """One GloverecError line naming the first feature where the policy and the environment differ."""
    u = env.unwrapped
    where = f"{task} on {robot}"
    spaces = env.observation_space.spaces
    names = agent.context.get("names") or {}
    env_names = {
        "observation.state": u.state_names,
        "observation.environment_state": u.environment_state_names,
        "action": u.action_names,
    }
    expected = {**agent.inputs, "action": agent.policy.config.action_feature}
    for key, ft in expected.items():
        if ft is None:
            raise GloverecError(f"the policy in {agent.path} has no '{key}' output")
        if key == "action":
            have = tuple(env.action_space.shape)
        elif key not in spaces:
            raise GloverecError(
                f"feature {key} differs: the policy reads it but {where} does not observe it "
                f"(it observes {', '.join(sorted(spaces))})"
            )
        else:
            have = tuple(spaces[key].shape)
            if key.startswith("observation.images."):
                have = (have[2], have[0], have[1])
        want = tuple(ft.shape)
        if want != have:
            raise GloverecError(f"feature {key} differs: the policy expects shape {want}, {where} gives {have}")
        mine, theirs = names.get(key), env_names.get(key)
        if mine and theirs and list(mine) != list(theirs):
            i = next(i for i, (a, b) in enumerate(zip(mine, theirs)) if a != b)
            raise GloverecError(
                f"feature {key} differs: element {i} is {mine[i]!r} for the policy but {theirs[i]!r} "
                f"in {where} (trained on another robot or task?)"
            )


def load_for_recording(path: str | Path, env, task: str, robot: str, fps: float) -> PolicyAgent:
    """A checkpoint that will drive ``env``, a takeover recording's (`gloverec record --policy`): one line when it
    was trained for another task, robot or rate, or reads what ``env`` does not observe."""
    agent = load_policy(path)
    trained_task, trained_robot = trained_setup(agent.context)
    if (trained_task and trained_task != task) or (trained_robot and trained_robot != robot):
        trained = f"{trained_task or '?'} on {trained_robot or '?'}"
        raise GloverecError(f"the policy in {agent.path} was trained for {trained}, not {task} on {robot}")
    trained_fps = agent.context.get("fps")
    if trained_fps and float(trained_fps) != float(fps):
        raise GloverecError(f"the policy in {agent.path} acts at {trained_fps:g} Hz: record with --fps {trained_fps:g}")
    check_features(agent, env, task, robot)
    check_instructions(agent, env)
    return agent


# ---------------------------------------------------------------- the harness


def make_env(task: str, robot: str, video_size=None, **options):
    """The task's environment on the robot; ``video_size`` (H, W): the size of its render()'s frames (videos),
    when not its cameras' (a camera policy's 84 px input)."""
    try:
        env = envs.make(task, robot, **options)
    except ValueError as exc:
        raise GloverecError(str(exc)) from None
    env.unwrapped.video_size = video_size
    return env


@dataclass(frozen=True)
class EvalJob:
    """What a process needs to build an evaluation's agent and environment (picklable, for ``workers``):
    ``policy`` a checkpoint folder or a baseline's name (BASELINES), ``options`` make_env's."""

    policy: str
    task: str
    robot: str
    options: dict = field(default_factory=dict)
    video_dir: str | None = None
    videos: int = 2


def build_agent(job: EvalJob):
    if job.policy in BASELINES:
        return BASELINES[job.policy](job.task, job.robot)
    return load_policy(job.policy)


def run_episode(agent, env, k: int, seed: int, video_dir=None, videos: int = 0) -> tuple[dict, str | None]:
    """Episode ``k`` of an evaluation, with seed ``seed`` (the environment's and torch's: a policy that samples
    draws the same numbers in any process); filmed into ``video_dir`` when ``k < videos`` (a folder, or a FILE.mp4
    for one episode: recorder.paths.video_file)."""
    torch.manual_seed(seed)
    obs, info = env.reset(seed=seed)
    agent.reset(env, seed)
    filming = video_dir is not None and k < videos
    frames = [env.render()] if filming else None
    ret, steps = 0.0, 0
    while True:
        obs, reward, terminated, truncated, info = env.step(agent.act(obs))
        ret += reward
        steps += 1
        if filming:
            frames.append(env.render())
        if terminated or truncated:
            break
    ok = bool(info["is_success"])
    run = {
        "seed": seed,
        "success": ok,
        "return": round(ret, 4),
        "length": steps,
        **{key: info[key] for key in ("goal", "object") if key in info},
        **_outcome(info),
    }
    path = None
    if filming:
        name = f"episode{k:03d}_seed{seed}_{'success' if ok else 'failure'}.mp4"
        path = str(_write_video(video_file(video_dir, name), frames, float(env.unwrapped.config.control_hz)))
    return run, path


def evaluate(
    agent,
    env,
    episodes: int,
    seed: int = EVAL_SEED,
    video_dir: str | Path | None = None,
    videos: int = 2,
    progress: bool = False,
) -> dict:
    """Run ``episodes`` episodes (seeds seed, seed+1, ...) in this process; videos of the first ``videos`` into
    ``video_dir``."""
    t0 = time.perf_counter()
    done = [
        run_episode(agent, env, k, seed + k, video_dir, videos)
        for k in tqdm(range(episodes), desc="evaluating", unit="episode", disable=not progress, file=sys.stderr)
    ]
    u = env.unwrapped
    return summarize(agent.name, u.task_name, u.robot.config.name, done, seed, t0)


def worker_pool(workers: int):
    """``workers`` spawned evaluation processes (a context manager; None for one worker), to be started before
    this process loads the policy: their imports (torch, LeRobot, MuJoCo: seconds each) run meanwhile. Spawned, not
    forked: a forked EGL context or torch thread pool does not survive. Each builds the agent and environment of the
    jobs it is given, and keeps them for the next episode of the same job."""
    if workers <= 1:
        return contextlib.nullcontext(None)
    return multiprocessing.get_context("spawn").Pool(workers, initializer=_worker_start)


def evaluate_job(job: EvalJob, episodes: int, seed: int = EVAL_SEED, pool=None, progress: bool = False,
                 agent=None, env=None) -> dict:  # fmt: skip
    """Evaluate ``job`` in this process (``agent``, ``env``: the job's, built already; the caller closes ``env``)
    or, given a ``worker_pool``, in its processes, each running whole episodes: the same per-seed results."""
    if pool is None or episodes <= 1:
        agent = agent or build_agent(job)
        own = env is None
        env = make_env(job.task, job.robot, **job.options) if own else env
        try:
            return evaluate(agent, env, episodes, seed, job.video_dir, job.videos, progress)
        finally:
            if own:
                env.close()
    t0 = time.perf_counter()
    done, name = {}, None
    bar = tqdm(total=episodes, desc="evaluating", unit="episode", disable=not progress, file=sys.stderr)
    for k, who, result in pool.imap_unordered(_worker_episode, [(job, k, seed + k) for k in range(episodes)]):
        done[k], name = result, who
        bar.update()
    bar.close()
    return summarize(name, job.task, job.robot, [done[k] for k in range(episodes)], seed, t0)


_WORKER: dict = {}


def _worker_start() -> None:
    """A pool process: one torch thread, lerobot's chatter off, nothing on stdout (it may carry --json's object)."""
    sys.stdout = sys.stderr
    logging.getLogger().setLevel(logging.WARNING)
    torch.set_num_threads(1)


def _worker_episode(item: tuple[EvalJob, int, int]) -> tuple[int, str, tuple[dict, str | None]]:
    job, k, s = item
    if _WORKER.get("policy") != job.policy:
        _WORKER.update(policy=job.policy, agent=build_agent(job))
    where = (job.task, job.robot, job.options)
    if _WORKER.get("where") != where:
        if "env" in _WORKER:
            _WORKER["env"].close()
        _WORKER.update(where=where, env=make_env(job.task, job.robot, **job.options))
    agent = _WORKER["agent"]
    return k, agent.name, run_episode(agent, _WORKER["env"], k, s, job.video_dir, job.videos)


def summarize(name: str, task: str, robot: str, done: list[tuple[dict, str | None]], seed: int, t0: float) -> dict:
    """An evaluation's result from its episodes (run, video path), in seed order."""
    runs = [r for r, _ in done]
    n = len(runs)
    return {
        "agent": name,
        "task": task,
        "robot": robot,
        "episodes": n,
        "seeds": [seed, seed + n - 1] if n else [],
        "success_rate": round(sum(r["success"] for r in runs) / n, 4) if n else 0.0,
        "successes": sum(r["success"] for r in runs),
        "mean_return": round(float(np.mean([r["return"] for r in runs])), 4) if n else 0.0,
        "mean_length": round(float(np.mean([r["length"] for r in runs])), 2) if n else 0.0,
        "episode_lengths": [r["length"] for r in runs],
        "videos": [p for _, p in done if p],
        "runs": runs,
        "wall_s": round(time.perf_counter() - t0, 2),
    }


def _outcome(info: dict) -> dict:
    """What a task says about how its episode ended (pinch's finger, keys' sequence and failure, turn's angle and
    target): its info's plain values, beside the success flag."""
    skip = {"is_success", "t", "applied_action", "goal", "object"}
    return {k: v for k, v in info.items() if k not in skip and isinstance(v, (str, int, float, bool, type(None)))}


def _write_video(path: Path, frames: list, fps: float) -> Path:
    # lerobot 0.6 writes through PyAV, whose stream rate must be an int or a Fraction (a float raises)
    write_video(str(path), np.stack(frames), fps=Fraction(fps).limit_denominator(1001))
    return path


def evaluate_checkpoint(
    path: str | Path,
    task: str | None,
    robot: str | None,
    episodes: int,
    seed: int = EVAL_SEED,
    video_dir=None,
    videos: int = 2,
    progress: bool = False,
    workers: int = 1,
    perturbations: tuple[str, ...] = (),
) -> dict:
    """Load a checkpoint, build the environment it needs, check the features, evaluate (in ``workers``
    processes), then again under each of ``perturbations`` (envs/tasks/perturb.py)."""
    with worker_pool(workers) as pool:
        agent = load_policy(path)
        guess_task, guess_robot = trained_setup(agent.context)
        task, robot = task or guess_task, robot or guess_robot
        if not task or not robot:
            missing = " and ".join(f"--{n}" for n, v in (("task", task), ("robot", robot)) if not v)
            raise GloverecError(f"the checkpoint does not say which task and robot it was trained on: pass {missing}")
        options = {"render_mode": "rgb_array" if video_dir else None,
                   **env_options(agent, bool(video_dir), task, robot)}  # fmt: skip
        env = make_env(task, robot, **options)
        try:
            check_features(agent, env, task, robot)
            check_instructions(agent, env)
            _warn_seed_overlap(agent.context, seed, episodes)
            job = EvalJob(str(agent.path), task, robot, options, None if video_dir is None else str(video_dir), videos)
            out = evaluate_job(job, episodes, seed, pool, progress, agent=agent, env=env)
        finally:
            env.close()
        return {"policy": str(agent.path), "policy_type": agent.type, **out,
                **perturbed(job, episodes, seed, pool, progress, perturbations, agent)}  # fmt: skip


def evaluate_baseline(name: str, task: str, robot: str, episodes: int, seed: int = EVAL_SEED, video_dir=None,
                      videos: int = 2, progress: bool = False, workers: int = 1,
                      perturbations: tuple[str, ...] = ()) -> dict:  # fmt: skip
    """A baseline agent (BASELINES: the scripted demonstrator, random actions, a fist) in ``task`` on ``robot``."""
    options = {"render_mode": "rgb_array" if video_dir else None, **({"image_size": VIDEO_SIZE} if video_dir else {})}
    job = EvalJob(name, task, robot, options, None if video_dir is None else str(video_dir), videos)
    with worker_pool(workers) as pool:
        return {"policy": name, "policy_type": name, **evaluate_job(job, episodes, seed, pool, progress),
                **perturbed(job, episodes, seed, pool, progress, perturbations)}  # fmt: skip


def perturbed(job: EvalJob, episodes: int, seed: int, pool, progress: bool, names: tuple[str, ...],
              agent=None) -> dict:  # fmt: skip
    """``{"perturbed": {name: result}}``: the same episodes under each perturbation (no videos), or {} for none."""
    if not names:
        return {}
    out = {}
    for name in names:
        options = {**job.options, "perturb": (name,)}
        result = evaluate_job(replace(job, options=options, video_dir=None), episodes, seed, pool, progress, agent)
        out[name] = {k: result[k] for k in ("success_rate", "successes", "episodes", "runs", "wall_s")}
    return {"perturbed": out}


def check_instructions(agent: PolicyAgent, env) -> None:
    """A policy that reads the instruction in an environment that can draw one it does not know: one line. One it
    knows but its training set never had (a few demonstrations of a task with many): its episodes test an untrained
    embedding; a warning says so once."""
    cfg = agent.policy.config
    if not agent.reads_task:
        return
    drawn = env.unwrapped.instructions()
    unknown = [t for t in drawn if t not in cfg.instructions]
    if unknown:
        trained = trained_setup(agent.context)[0]
        raise GloverecError(
            f"the policy in {agent.path} does not know the instruction {unknown[0]!r}, which "
            f"{env.unwrapped.task_name} can draw: it was trained for {trained or 'another task'}"
            + (" with another task config" if trained == env.unwrapped.task_name else "")
        )
    untrained = [t for t in drawn if t not in (cfg.trained_instructions or cfg.instructions)]
    if untrained:
        print(
            f"warning: {len(untrained)} of the task's {len(drawn)} instructions never came up in the policy's "
            f"training set (e.g. {untrained[0]!r}): episodes that draw them test a guess",
            file=sys.stderr,
        )


def _warn_seed_overlap(context: dict, seed: int, episodes: int) -> None:
    root = (context.get("dataset") or {}).get("root")
    if not root or not Path(root).exists():
        return

    used = {e.get("seed") for e in sidecar(Path(root)).values()}
    overlap = used & set(range(seed, seed + episodes))
    if overlap:
        print(
            f"warning: {len(overlap)} evaluation seed(s) are seeds of training episodes (e.g. {min(overlap)}): "
            "pass another --seed to evaluate on unseen episodes",
            file=sys.stderr,
        )
