"""What the grasping demonstrators share: the fingers' timing around the base's descent, and the wearer's wrist when
a tracker frees it (a task's ``base_position``).

``grip`` is HandGrasp's and HandPinch's plan: hold the start posture, open into the approach posture, and close a
human reaction time after the base has stopped. With a free wrist the wearer also does what the task's script would
do with the base (``follow_script``): each of its moves (descend, lift, tilt) starts a reaction time after the
script's and arrives when the script's does, a few millimetres off its path (``aim_error``, as the relocate
demonstrator aims)."""

from __future__ import annotations

import numpy as np

from recorder import quat
from recorder.demonstrator.motion import DemoMotion
from recorder.demonstrator.watching import GripWatcher


def aim_error(rng: np.random.Generator, sd_mm: float) -> np.ndarray:
    """A person's aim error in the horizontal plane (m, x and y): normal, ``sd_mm`` each, cut at 2.5 deviations."""
    sd = sd_mm * 1e-3
    return np.clip(rng.normal(0, sd, 2), -2.5 * sd, 2.5 * sd)


def follow_script(env, rng: np.random.Generator, reaction_s: tuple, aim_mm: float):
    """The task's base script (``env.schedule``'s phases, ``env._base_target``) as the wearer's wrist does it:
    keyframe times (k,), palm positions (k, 3, m, world) and palm turns (k, 3, rotation vectors)."""
    bounds = sorted(set(env.schedule.values()))
    path = [(p, quat.to_rotvec(q)) for p, q in (env._base_target(t) for t in bounds)]
    off = None  # the first move's aim error, kept for the rest (the lift goes straight up)
    keys = [(bounds[0], *path[0])]
    for k in range(1, len(bounds)):
        (p0, r0), (p, r) = path[k - 1], path[k]
        if np.allclose(p, p0) and np.allclose(r, r0):
            continue  # the script holds
        if off is None:
            off = np.array([*aim_error(rng, aim_mm), 0.0])
        a, b = bounds[k - 1], bounds[k]
        keys.append((a + min(rng.uniform(*reaction_s), 0.5 * (b - a)), *keys[-1][1:]))
        keys.append((b, p + off, r))
    times, positions, turns = zip(*keys)
    return np.array(times), np.array(positions), np.array(turns)


def _moves(times, values) -> list:
    return [(times[i], times[i + 1]) for i in range(len(times) - 1) if not np.allclose(values[i], values[i + 1])]


def merge(*tracks):
    """Keyframe tracks (times (k,), values (k, n)) on one timeline: a move of one that overlaps a move of another
    becomes one move spanning both (splitting a minimum-jerk move would stop it halfway); the holds are kept.
    Returns the times and each track's values at them."""
    spans: list = []
    for a, b in sorted(m for t in tracks for m in _moves(*t)):
        if spans and a < spans[-1][1]:
            spans[-1][1] = max(spans[-1][1], b)
        else:
            spans.append([a, b])
    times = {t for s in spans for t in s}
    times |= {t for tr in tracks for t in tr[0] if not any(a < t < b for a, b in spans)}
    times = np.array(sorted(times))
    at = [np.clip(np.searchsorted(tr[0], times, side="right") - 1, 0, None) for tr in tracks]
    return times, *(np.asarray(tr[1])[k] for tr, k in zip(tracks, at))


def grip(env, rng: np.random.Generator, c, start, opened, closed, digits, **motion) -> DemoMotion:
    """Hold ``start`` for ``c.pre_s``, open into ``opened`` in ``c.preshape_s``, close into ``closed`` in ``c.close_s``,
    ``c.reaction_s`` after the script's base stops (``env.schedule["close"]``) or once open if that is later, and
    keep it; with a free wrist, the wearer's wrist follows the script (``c.wrist_reaction_s``, ``c.aim_mm``). With
    ``c.sight`` the wearer watches ``digits`` (thumb first) close on the object and corrects them
    (recorder/demonstrator/watching.py); None: open loop."""
    t_pre = rng.uniform(*c.pre_s)
    t_open = t_pre + rng.uniform(*c.preshape_s)
    t_close = max(env.schedule["close"] + rng.uniform(*c.reaction_s), t_open)  # a slow opening is finished first
    t_closed = t_close + rng.uniform(*c.close_s)
    end = max(t_closed, env.config.episode_s) + 1.0
    times = [0.0, t_pre, t_open, t_close, t_closed, end]
    poses = [start, start, opened, opened, closed, closed]
    if env.config.base_position:
        w_times, positions, turns = follow_script(env, rng, c.wrist_reaction_s, c.aim_mm)
        times, poses, wrist = merge((times, poses), (w_times, np.hstack((positions, turns))))
        motion.update(palm_pos=wrist[:, :3], palm_turns=wrist[:, 3:])
    m = DemoMotion(times, poses, rng, c.rate_hz, **motion)
    if c.sight is not None:  # drawn after the plan's draws: the open-loop wearer's plan of a seed is the same
        sight_rng = np.random.default_rng(rng.integers(2**32))
        m.watcher = GripWatcher(digits, closed - opened, t_closed, sight_rng, c.sight)
    return m
