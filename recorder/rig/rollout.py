"""Run scripted demonstrations through retargeting into an environment and score them.

    python -m recorder.rig.rollout --task grasp --robot shadow --episodes 50 [--via glove]
        [--retarget ik|pinch]

``via="direct"``: the demonstrator's joint angles and palm orientation go straight to the retargeter.
``via="glove"``: they drive a SyntheticGlove; its pose output (parent-relative quaternions with orientation
noise) is turned back into joint angles as a host would (kinematics.joint_angles_from_relative; palm =
quats[0]) and read ``latency_s`` late. ``via="glove+marker"`` (a free-wrist task): the same glove, and the wrist
from an emulated webcam filming the glove's marker (recorder/wrist/emulated.py) fused with the glove's palm
(recorder/wrist/fusion.py). Prints one JSON object: success rate and per-episode details.

The session's parts come from the rig (recorder/rig/rig.py): the task environment, the retargeter and the
demonstrator (``success_rate``), the wrist track and its zero (``via="glove+marker"``). The glove here is a model of
one, not a link: the demonstration's frames synthesised as the host would fuse them, with no pseudo-terminal, so
that fifty episodes take seconds (`gloverec record --glove emulator` runs the whole path).
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

from recorder import GloverecError
from recorder.config import add_option
from recorder.demonstrator import make_demonstrator
from recorder.emulator.glove import SyntheticGlove
from recorder.hand.kinematics import JOINTS, joint_angles_from_relative
from recorder.retarget import MODES
from recorder.rig.config import SessionConfig
from recorder.rig.rig import Rig, wrist_track, zero_wrist
from recorder.wrist.emulated import EmulatedCamera
from recorder.wrist.track import EmulatedMarker

VIA = ("direct", "glove", "glove+marker")


class _GloveReader:
    """The demonstration as a glove host sees it: noisy pose frames at the glove rate, ``latency_s`` late, synthesised
    as time goes (a demonstrator that watches may revise what is still ahead)."""

    def __init__(self, motion, seed: int, latency_s: float, noise_deg: float, bias=None):
        self.rate = motion.rate_hz
        self.bias = np.zeros(len(JOINTS))  # a fused pose's standing error, rad per joint (a joint name: degrees)
        for name, deg in (bias or {}).items():
            self.bias[JOINTS.index(name)] = np.radians(deg)
        self.glove = SyntheticGlove(motion, rate_hz=self.rate, seed=seed, pose_noise_deg=noise_deg)
        self.angles, self.palm = np.zeros((0, 20)), np.zeros((0, 4))
        self.latency = latency_s
        self.motion = motion

    def __call__(self, t: float):
        i = max(int(np.floor((t - self.latency) * self.rate + 1e-9)), 0)
        if i >= len(self.angles):
            block = self.glove.next_block(i + 1 - len(self.angles))
            self.angles = np.concatenate((self.angles, joint_angles_from_relative(block.pose.astype(float))))
            self.palm = np.concatenate((self.palm, block.pose[:, 0].astype(float)))
        return self.angles[i] + self.bias, self.palm[i], self.motion.at([i / self.rate]).palm_pos[0]


class _TrackedWrist:
    """The glove reader's hand, with the wrist from an emulated webcam filming the demonstration's palm, tracked
    and fused with the glove's palm as `gloverec record --wrist marker:emulated` does (recorder/wrist/track.py),
    on the glove samples' clock; the wearer holds still in the start pose until the first frame has come."""

    def __init__(self, glove: _GloveReader, motion, camera, env):
        def truth(t: float):
            b = motion.at([t])
            return b.palm_pos[0], b.palm_quat[0]

        self.glove, self.lost = glove, 0
        self.track = wrist_track(EmulatedMarker(truth, camera))  # fused with the camera's latency
        waited = iter(np.arange(1, 31) / camera.fps)

        def wait() -> float:
            t = next(waited, None)
            if t is None:
                raise GloverecError("the emulated webcam did not see the marker at the start pose in 1 s")
            return float(t)

        zero_wrist(self.track, env, 0.0, glove(0.0)[1], wait)

    def __call__(self, t: float):
        angles, palm, _ = self.glove(t)
        t_sample = t - self.glove.latency
        self.track.update(t_sample, palm)
        fused = self.track.pose(t_sample)
        self.lost += not fused.tracked
        return angles, fused.quat, fused.position


def run_episode(
    env,
    retargeter,
    seed: int,
    via: str = "direct",
    latency_s: float = 0.02,
    noise_deg: float = 0.5,
    demonstrator=None,
    on_step=None,
    camera=None,
    push=None,
    bias=None,
) -> dict:
    """One demonstration on ``env`` (reset with ``seed``); returns success, steps and retarget error. ``push``: (time
    s, offset (x, y) m): the object displaced by that much then (``displace_object``), mid-take. ``bias`` ({joint
    name: degrees}, via glove): a standing error in the angles the host reads, as the fused thumb's (its abduction
    is a heading the glove's accelerometers cannot see: 7-14 degrees off in some takes through the whole
    recording path)."""
    obs, info = env.reset(seed=seed)
    u = env.unwrapped
    demo = demonstrator or make_demonstrator(u.task_name)
    motion = demo.plan(u, seed=seed)
    retargeter.reset()
    if via == "glove":
        read = _GloveReader(motion, seed, latency_s, noise_deg, bias)
    elif via == "glove+marker":
        if camera is None:
            camera = EmulatedCamera()
        try:
            read = _TrackedWrist(_GloveReader(motion, seed, latency_s, noise_deg), motion, camera, env)
        except GloverecError as exc:  # the wearer cannot start: a failed take, not a failed run
            return {"seed": seed, "success": False, "steps": 0, "error": str(exc)}
    elif via == "direct":

        def read(t):
            b = motion.at([t])
            return b.angles[0], b.palm_quat[0], b.palm_pos[0]
    else:
        raise ValueError(f"unknown via {via!r}; valid: {', '.join(VIA)}")
    errors = []
    steps = 0
    while True:
        angles, palm, palm_pos = read(u.t)
        action, rinfo = retargeter(angles, palm, palm_pos)
        errors.append(rinfo["tip_error_mean"])
        obs, reward, terminated, truncated, info = env.step(action)
        if push is not None and u.t >= push[0]:
            u.displace_object(push[1])
            push = None
        motion.watch(u)
        steps += 1
        if on_step is not None:
            on_step(obs, action, info)
        if terminated or truncated:
            break
    return {
        "seed": seed,
        "success": bool(info["is_success"]),
        "steps": steps,
        "tip_error_mm": round(1000 * float(np.mean(errors)), 2),
        **({"wrist_untracked_steps": read.lost} if isinstance(read, _TrackedWrist) else {}),
        **{k: info[k] for k in ("goal", "object") if k in info},
        **({"intent": motion.intent} if motion.intent is not None else {}),
        **({"failed_because": why} if not info["is_success"] and (why := u.failure()) else {}),
    }


PUSH_S = (0.4, 0.9)  # when a take's object is pushed: during the reach, before the hand is over it


def pushed(seed: int, cm) -> tuple:
    """The push of take ``seed``: (time s, offset (x, y) m), ``cm`` (low, high) far in a random direction."""
    rng = np.random.default_rng([seed, 0x9054])
    angle, r = rng.uniform(0, 2 * np.pi), rng.uniform(*cm) / 100
    return float(rng.uniform(*PUSH_S)), (r * np.cos(angle), r * np.sin(angle))


def success_rate(
    task: str, robot: str, episodes: int, via: str = "direct", mode: str = "joint", seed0: int = 0,
    demonstrator: str = "scripted", failure_rate: float | None = None, watches: bool = True, push_cm=None,
    **env_kwargs,
) -> dict:  # fmt: skip
    """The demonstrator's success over ``episodes`` seeds from ``seed0``; ``push_cm`` (low, high): each take's object
    displaced that far mid-take (``pushed``)."""

    rig = Rig(
        SessionConfig(task=task, robot=robot, retarget=mode),
        options=env_kwargs,
        seed=None,
        demonstrator=demonstrator,
        failure_rate=failure_rate,
        watches=watches,
    )
    env, r = rig.env, rig.retarget
    t0 = time.perf_counter()
    camera = None
    if via == "glove+marker":
        camera = EmulatedCamera()
    seeds = range(seed0, seed0 + episodes)
    runs = [run_episode(env, r, seed, via, demonstrator=rig.demonstrator, camera=camera,
                        push=None if push_cm is None else pushed(seed, push_cm)) for seed in seeds]  # fmt: skip
    rig.close()
    if camera is not None:
        camera.close()
    ok = sum(r["success"] for r in runs)
    return {
        "task": task,
        "robot": robot,
        "via": via,
        "mode": mode,
        "demonstrator": demonstrator,
        "watches": watches,
        "episodes": episodes,
        "success_rate": round(ok / episodes, 3),
        "successes": ok,
        "mean_tip_error_mm": round(float(np.mean([r["tip_error_mm"] for r in runs if "tip_error_mm" in r])), 2),
        "wall_s": round(time.perf_counter() - t0, 2),
        "runs": runs,
    }


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--task", default="pose")
    p.add_argument("--robot", default="glovehand")
    p.add_argument("--episodes", type=int, default=20)
    p.add_argument("--via", choices=VIA, default="direct")
    add_option(p, "--retarget", "--mode", choices=MODES, default="joint", help="retargeting mode (as record's)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--free-wrist", action="store_true", help="base_position: the wearer's wrist moves the base")
    p.add_argument("--demonstrator", choices=("scripted", "human"), default="scripted")
    p.add_argument("--failure-rate", type=float, help="--demonstrator human: the share of failed takes (0.15)")
    p.add_argument("--open-loop", action="store_true", help="the wearer never looks at the robot hand (grasp, pinch)")
    p.add_argument("--push-cm", type=float, nargs=2, metavar=("LOW", "HIGH"),
                   help="each take's object pushed this far mid-take (relocate: during the reach)")  # fmt: skip
    p.add_argument("--brief", action="store_true", help="leave out the per-episode runs")
    args = p.parse_args(argv)
    free = {"base_position": True} if args.free_wrist else {}
    out = success_rate(args.task, args.robot, args.episodes, args.via, args.retarget, args.seed, args.demonstrator,
                       args.failure_rate, not args.open_loop, args.push_cm, **free)  # fmt: skip
    if args.brief:
        out.pop("runs")
    print(json.dumps(out))


if __name__ == "__main__":
    main()
