"""`gloverec generate`: many demonstrations from a person's few, generated in simulation (MimicGen, Mandlekar et al.
2023; DexMimicGen, Jiang et al. 2024, for dexterous hands).

1. **Segment the sources.** Each successful episode of the source dataset is replayed from its seed (the recorded
   actions, open loop: MuJoCo is deterministic, so the replay is the recording, and a source whose replay drifts
   from its recorded states is left out, with a warning). The task's segmentation (envs/tasks/segments.py,
   registered with the task) reads the simulator's events on every frame (contact begins or ends, the object
   lifts, the knob turns) and splits the episode into segments, each following a frame of the scene (the object,
   the target circle) or none.
2. **Generate a scene.** The environment is reset with a new seed (``--seeds``; ``--scene KEY=VALUE`` widens what
   the task draws). The source that fits it best is taken (the task's ``distance``: the same shape, the nearest
   size, ...), and its segments are executed one after another: at each segment's start the frame it follows is
   read in the new scene, and the free wrist's positions of the segment are moved by how far that frame lies from
   where it lay in the source at the same point. The jump this leaves at the start of a segment (from where the
   hand is to where the moved segment begins) fades out smoothly over the segment's first half (``FADE``), so
   segments join without a step and the rest of each is the person's motion, moved.
   The hand's joints are the person's, frame for frame; a fixed-base task adapts the actions instead (turn: the
   palm's turn scaled to the new target). After the source's last frame the last action holds.
3. **Keep what succeeds.** An episode is saved only if the task succeeds; the others are dropped. The dataset is
   written through the recorder's crash-safe store and writer process (recorder/record/store.py, writer.py), so a
   killed generation loses at most the episode in progress.

``--dart SCALE`` adds DART's noise (recorder/record/dart.py, the recorder's own) to the executed actions, with the
generated action kept as ``expert.action``. The plan runs open loop, so nothing steers back: the takes the noise
spoils are dropped, and the kept ones show the noise with the plan's own next targets.

What a generated episode holds where the recorder stores a glove: ``observation.glove``, ``quality.glove_valid``,
``quality.fusion`` and ``quality.retarget_error_mm`` are the source frame's (the person's hand as the glove
measured it, at the frame the action came from); ``quality.latency_ms`` is -1 (not measured) and
``quality.glove_age_ms`` 0. There was no glove clock: ``time.device_s`` is a generation clock, ``DEVICE_BASE_S``
plus ``DEVICE_STRIDE_S`` per episode index plus the frame's time, so that each episode's first frame time, which
the sidecar matches episodes by, is unique and far from any glove's (a glove's clock starts at 0 when it powers
up).
``time.host_s`` is the host's monotonic clock as the frame was generated. A free wrist's ``observation.wrist``
is the action's palm pose, always tracked.
"""

from __future__ import annotations

import re
import sys
import time
from dataclasses import dataclass, field

import numpy as np

import envs
from envs.tasks.base import BASE_POSITION
from policies.dataref import DatasetRef, recorded_options, sidecar
from recorder import GloverecError, quat
from recorder.hand.motion import min_jerk
from recorder.hand.pose import HandPose
from recorder.record.dart import Dart
from recorder.record.features import DatasetSchema, Row
from recorder.record.store import EpisodeStore, check_root
from recorder.record.writer import EpisodeWriter
from recorder.wrist.fusion import FusedWrist

DEVICE_BASE_S = 1.0e6  # a generated episode's time.device_s starts here + DEVICE_STRIDE_S per episode index
DEVICE_STRIDE_S = 1000.0  # longer than any episode
FADE = 0.5  # the jump into a moved segment fades over this share of it; the rest is the source, moved
DRIFT = 1e-4  # a source whose replay leaves its recorded states by more is not used
GLOVE_COLUMNS = ("observation.glove", "quality.glove_valid", "quality.fusion", "quality.retarget_error_mm")


@dataclass
class Source:
    """One successful source episode, replayed and segmented."""

    episode: int
    seed: int
    actions: np.ndarray  # (n, A) float32, as recorded
    glove: dict  # GLOVE_COLUMNS -> (n, ...) arrays
    segments: list  # envs.tasks.segments.Segment
    anchors: list[dict]  # per segment: the frames' positions at its start
    scene: dict

    def glove_at(self, k: int) -> dict:
        """The glove columns of frame ``k`` (its last frame past the end)."""
        k = min(k, len(self.actions) - 1)
        return {c: v[k] for c, v in self.glove.items()}


@dataclass
class GenerateConfig:
    episodes: int = 100  # accepted episodes wanted
    seed: int = 10000  # the first new scene's seed, then +1 each attempt
    max_attempts: int | None = None  # default: 5 per episode wanted
    scene: dict = field(default_factory=dict)  # task config overrides: wider ranges than the source's
    dart: float = 0.0
    dart_time_s: float = 0.2
    resume: bool = False  # add to a generated dataset until it holds ``episodes``, on the seeds after its last


def check_source(ref: DatasetRef):
    """The task spec and the sidecar records of a dataset that can be generated from; else one line."""
    from envs.tasks.registry import get_task

    records = sidecar(ref.root)
    if not records:
        raise GloverecError(f"{ref.root} has no gloverec episode records (meta/gloverec/episodes.jsonl): generate "
                            "needs each episode's seed and task, as `gloverec record` writes them")  # fmt: skip
    first = records[min(records)]
    name = first.get("env_task")
    if not name:
        raise GloverecError(f"{ref.root}: its episode records do not name the task")
    spec = get_task(name)  # unknown: one line listing the tasks
    if spec.segmentation is None:
        from envs.tasks.registry import task_names

        can = [t for t in task_names() if get_task(t).segmentation is not None]
        raise GloverecError(f"the {name} task has no segmentation, so it cannot be generated from (tasks that "
                            f"have one: {', '.join(can)})")  # fmt: skip
    good = {i: r for i, r in records.items() if r.get("success") and r.get("seed") is not None}
    if not good:
        raise GloverecError(f"{ref.root} has no successful episode with a seed to generate from")
    return spec, first, good


def load_sources(ref: DatasetRef, spec, records: dict, options: dict, robot: str, say=print) -> list[Source]:
    """Replay and segment each successful episode of ``ref`` (``records``: their sidecar records)."""
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    from recorder.video_backend import video_backend

    ds = LeRobotDataset(ref.repo_id, root=ref.root, episodes=sorted(records), video_backend=video_backend())
    rows = ds.hf_dataset
    columns = ["episode_index", "action", "observation.state", "observation.environment_state", *GLOVE_COLUMNS]
    rows.set_format("numpy", columns=[c for c in columns if c in rows.column_names])
    table = rows[:]
    env = envs.make(spec.name, robot, **options)
    u, seg = env.unwrapped, spec.segmentation
    sources = []
    try:
        for episode, record in sorted(records.items()):
            mine = table["episode_index"] == episode
            actions = np.asarray(table["action"][mine], np.float32)
            states = {k: table[k][mine] for k in ("observation.state", "observation.environment_state")}
            obs, _ = env.reset(seed=int(record["seed"]))
            trace, anchors, drift = [], [], 0.0
            for k, a in enumerate(actions):
                drift = max(drift, *(float(np.abs(obs[key] - states[key][k]).max(initial=0)) for key in states))
                trace.append(seg.observe(u))
                anchors.append(seg.anchors(u))
                obs, *_ = env.step(a)
            if drift > DRIFT:
                say(f"warning: episode {episode} does not replay as recorded (its states drift {drift:.3g}): "
                    "left out")  # fmt: skip
                continue
            events = {key: np.array([t[key] for t in trace]) for key in trace[0]}
            segments = seg.split(events)
            env.reset(seed=int(record["seed"]))
            glove = {c: table[c][mine] for c in GLOVE_COLUMNS if c in table}
            sources.append(Source(episode, int(record["seed"]), actions, glove, segments,
                                  [anchors[s.start] for s in segments], seg.scene(u)))  # fmt: skip
    finally:
        env.close()
    if not sources:
        raise GloverecError(f"none of the successful episodes of {ref.root} replays as recorded: nothing to "
                            "generate from (`gloverec replay` says where each one leaves its recording)")  # fmt: skip
    return sources


class Generator:
    """Generates scenes for one task and robot from segmented sources; ``step(frame)`` each frame as it is made."""

    def __init__(self, env, seg, sources: list[Source], dart: Dart | None):
        self.env, self.u, self.seg, self.sources, self.dart = env, env.unwrapped, seg, sources, dart
        names = self.u.action_names
        self.pos = slice(names.index(BASE_POSITION[0]), names.index(BASE_POSITION[0]) + 3) if (
            BASE_POSITION[0] in names) else None  # fmt: skip

    def choose(self, scene: dict) -> Source | None:
        """The source nearest the scene by the task's distance (None: none can serve it)."""
        best = min(self.sources, key=lambda s: self.seg.distance(s.scene, scene))
        return best if np.isfinite(self.seg.distance(best.scene, scene)) else None

    def run(self, seed: int, on_frame) -> dict:
        """One generated episode on scene ``seed``; ``on_frame(obs, action, intended, glove)`` per frame (glove:
        the source frame's glove columns). Returns what its record says of it (success, source, segments, how far
        the frames moved)."""
        env, u, seg = self.env, self.u, self.seg
        obs, _ = env.reset(seed=seed)
        scene = seg.scene(u)
        src = self.choose(scene)
        if src is None:
            return {"success": False, "why": "no source fits the scene", "scene": scene}
        if self.dart is not None:
            self.dart.reset(seed)
        actions = seg.adapt(src.actions.astype(np.float64), src.segments, src.scene, scene, u)
        moved: dict[str, float] = {}
        last = u.palm_pose()[0].copy()  # where the hand is: the first segment starts from here
        held = actions[0]
        success, done, k = False, False, 0
        for segment, anchors in zip(src.segments, src.anchors, strict=True):
            a = actions[segment.start : segment.end].copy()
            if self.pos is not None and segment.anchor is not None:
                now = seg.anchors(u)[segment.anchor]
                shift = now - anchors[segment.anchor]
                moved[segment.anchor] = max(moved.get(segment.anchor, 0.0), float(np.linalg.norm(shift)))
                a[:, self.pos] += shift
                jump = last - a[0, self.pos]  # from where the hand is to where the moved segment begins
                fade = 1.0 - min_jerk(np.arange(len(a)) / max(FADE * (len(a) - 1), 1))
                a[:, self.pos] += fade[:, None] * jump
            for row in a:
                obs, info, done = self._step(obs, row, src.glove_at(k), on_frame)
                k, held = k + 1, row
                success = bool(info["is_success"])
                if done:
                    break
                if self.pos is not None:
                    last = row[self.pos]
            if done:
                break
        while not done:  # the source's frames are over (it ended on success sooner): the last action holds
            obs, info, done = self._step(obs, held, src.glove_at(k), on_frame)
            success = bool(info["is_success"])
        return {"success": success, "source": src, "segments": [s.as_dict() for s in src.segments],
                "moved_m": {k: round(v, 4) for k, v in moved.items()}, "scene": scene}  # fmt: skip

    def _step(self, obs, action, glove: dict, on_frame):
        intended = self.u.clip_action(np.asarray(action, np.float32)).astype(np.float32)  # as stored: replays exactly
        executed = self.dart.perturb(intended) if self.dart is not None else intended
        nxt, _, terminated, truncated, info = self.env.step(executed)
        on_frame(obs, info["applied_action"], intended if self.dart is not None else None, glove)
        return nxt, info, terminated or truncated


def generate(ref: DatasetRef, root, repo_id: str, cfg: GenerateConfig, progress: bool = True, say=None) -> dict:
    """Generate ``cfg.episodes`` successful episodes from ``ref`` into a new dataset at ``root``."""
    from tqdm import tqdm

    say = say or (lambda text: print(text, file=sys.stderr, flush=True))
    spec, first, records = check_source(ref)
    check_root(root, resume=cfg.resume)
    have = _resumed(root, ref, cfg) if cfg.resume else []
    from policies.data import dataset_info

    info = dataset_info(ref.root)
    robot = first.get("robot") or info.get("robot_type")
    options = {**recorded_options(info, first), **cfg.scene}
    source_options = recorded_options(info, first)
    try:
        spec.config_class.load(spec.name, **options)  # a bad --scene: one line, before anything is written
    except ValueError as exc:
        raise GloverecError(f"--scene: {exc}") from None
    t0 = time.perf_counter()
    env = envs.make(spec.name, robot, **options)
    u = env.unwrapped
    fps = int(round(options["control_hz"]))
    space = env.action_space
    dart = Dart(cfg.dart, cfg.dart_time_s, space.low, space.high, fps) if cfg.dart else None
    schema = DatasetSchema(u, use_videos=bool(u.config.cameras), expert=dart is not None)
    store = EpisodeStore(root, repo_id, fps, schema.lerobot_features(), robot_type=robot, resume=cfg.resume,
                         use_videos=bool(u.config.cameras))  # fmt: skip
    writer = EpisodeWriter(store)  # forked before the sources load (LeRobot's reader starts threads)
    try:
        sources = load_sources(ref, spec, records, source_options, robot, say)
    except BaseException:
        writer.close()
        store.close(discard_empty=True)  # nothing published: a new folder is removed again
        env.close()
        raise
    gen = Generator(env, spec.segmentation, sources, dart)
    wanted = cfg.episodes - len(have)
    first_seed = max([cfg.seed, *(r["seed"] + 1 for r in have)])
    attempts = cfg.max_attempts or 5 * wanted
    accepted, tried, why = [], 0, {}
    bar = tqdm(total=wanted, desc=f"generating {spec.name} on {robot}", unit="episode", disable=not progress)
    try:
        while len(accepted) < wanted and tried < attempts:
            seed = first_seed + tried
            tried += 1
            index = store.next_index
            frames = _Frames(schema, store, u, index, fps)
            out = gen.run(seed, frames.add)
            if not out["success"]:
                store.discard_episode()
                reason = re.sub(r"\d+(\.\d+)?", "#", out.get("why") or u.failure() or "not a success")
                why[reason] = why.get(reason, 0) + 1
            else:
                src = out["source"]
                record = {
                    "task": u.instruction(), "seed": seed, "success": True, "robot": robot, "env_task": spec.name,
                    "repo_id": repo_id, "fps": fps, "glove": "none (generated)", "realtime": False,
                    "wearer": first.get("wearer"), "frames": frames.n, "start_device_time_s": frames.start,
                    "env_options": {k: list(v) if isinstance(v, tuple) else v for k, v in cfg.scene.items()},
                    "generated": {
                        "from": ref.as_dict(), "source_episode": src.episode, "source_seed": src.seed,
                        "segments": out["segments"], "moved_m": out["moved_m"], "scene": out["scene"],
                        "source_scene": src.scene, "dart": dart.summary() if dart is not None else None,
                    },
                }  # fmt: skip
                writer.submit(store.take_episode(), record)
                accepted.append(seed)
                bar.update(1)
            writer.results()
            bar.set_postfix_str(f"accepted {len(accepted)}/{tried} = {100 * len(accepted) / tried:.0f} %")
        writer.close()
    except BaseException:
        writer.close()
        raise
    finally:
        bar.close()
        store.close(discard_empty=True)
        env.close()
    wall = time.perf_counter() - t0
    return {
        "root": str(root), "repo_id": repo_id, "task": spec.name, "robot": robot, "from": ref.as_dict(),
        "sources": [s.episode for s in sources], "accepted": len(accepted), "attempts": tried,
        "acceptance_rate": len(accepted) / tried if tried else 0.0, "rejected_because": why,
        "seeds": [first_seed, first_seed + tried - 1] if tried else [], "wall_s": round(wall, 1),
        "episodes": len(have) + len(accepted), "wanted": wanted,
        "accepted_per_min": round(60 * len(accepted) / wall, 1) if wall else 0.0,
        "dart": dart.summary() if dart is not None else None, "scene": cfg.scene,
    }  # fmt: skip


def _resumed(root, ref: DatasetRef, cfg: GenerateConfig) -> list[dict]:
    """The episode records of the generated dataset ``root`` that a resumed generation adds to; one line if it
    was generated from another dataset or with other settings."""
    records = list(sidecar(root).values())
    if not records or "generated" not in records[0]:
        raise GloverecError(f"{root} was not made by gloverec generate: --resume adds to a generated dataset")
    made = records[0]
    if made["generated"]["from"]["root"] != str(ref.root):
        raise GloverecError(f"{root} was generated from {made['generated']['from']['root']}, not {ref.root}")
    scene = {k: tuple(v) if isinstance(v, list) else v for k, v in made.get("env_options", {}).items()}
    dart = (made["generated"].get("dart") or {}).get("scale", 0.0)
    if scene != cfg.scene or dart != cfg.dart:
        raise GloverecError(f"{root} was generated with --scene {made.get('env_options')} and --dart {dart}: "
                            "resume it with the same")  # fmt: skip
    if len(records) >= cfg.episodes:
        raise GloverecError(f"{root} holds {len(records)} episodes already (--episodes {cfg.episodes} is the total)")
    return records


class _Frames:
    """One generated episode's frames into the store, each a recorder Row with the source frame's glove columns."""

    def __init__(self, schema, store, u, index: int, fps: int):
        self.schema, self.store, self.u, self.fps = schema, store, u, fps
        self.start = DEVICE_BASE_S + DEVICE_STRIDE_S * index
        self.n = 0

    def add(self, obs, action, intended, glove: dict) -> None:
        pose = HandPose(glove["observation.glove"][:20].astype(float), glove["observation.glove"][20:].astype(float),
                        glove["quality.glove_valid"] > 0.5, float(np.ravel(glove["quality.fusion"])[0]))  # fmt: skip
        wrist = None
        if self.u.config.base_position:
            names = self.u.action_names
            p = names.index(BASE_POSITION[0])
            r = names.index("base.rx")
            wrist = FusedWrist(np.asarray(action[p : p + 3], float), quat.from_rotvec(action[r : r + 3]), True, 0.0)
        row = Row(obs, action, pose, None, 0.0, float(np.ravel(glove["quality.retarget_error_mm"])[0]) / 1e3,
                  time.monotonic(), self.start + self.n / self.fps, self.u.instruction(), wrist, None,
                  intended)  # fmt: skip
        self.store.add_frame(self.schema.frame(row))
        self.n += 1
