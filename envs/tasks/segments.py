"""How a task's demonstrations split into segments, for `gloverec generate` (policies/generate.py): MimicGen's
object-centric segments (Mandlekar et al. 2023), found from the simulator's own events.

A task declares its segmentation in its own module and registers it with the task (``register_task(...,
segmentation=...)``); a task without one cannot be generated from. A ``Segmentation`` says:

- ``observe(env)``: the events it splits on, read from the simulation after each step of the source episode's
  replay (contact begins or ends, the object lifts, the knob starts turning);
- ``split(trace)``: the segments, from those events per frame;
- ``anchors(env)``: where the frames the segments follow are now (the object, the target circle): the generator
  reads them at each segment's start, in the source's replay and in the new scene, and moves a free wrist's
  positions in that segment by the difference. The hand's joint trajectory is kept: it is the person's dexterity;
- ``scene(env)`` and ``distance(a, b)``: what describes a scene (the object's shape and size, the target's
  offset), to take the source that fits a new scene best (inf: it cannot serve);
- ``adapt(actions, segments, source, scene, env)``: what a fixed-base task changes in the actions for a new
  scene (the knob's turn scaled to its new target angle); the default keeps them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

LIFT_M = 0.01  # the object has lifted: its centre this much above where it started
OTHER_SHAPE = 1.0  # a source of another shape is this far from a scene (any of the same shape is nearer)


@dataclass(frozen=True)
class Segment:
    name: str
    start: int  # the first frame
    end: int  # one past the last
    anchor: str | None = None  # the frame a free wrist follows in it (a key of ``anchors``); None: as recorded

    def as_dict(self) -> dict:
        return {"name": self.name, "frames": [self.start, self.end], "anchor": self.anchor}


def first(flags: np.ndarray, start: int = 0) -> int | None:
    """The first frame from ``start`` on where ``flags`` holds (None: none)."""
    hits = np.flatnonzero(np.asarray(flags[start:], bool))
    return int(start + hits[0]) if len(hits) else None


def cut(names: tuple[str, ...], bounds: list[int | None], n: int, anchors: tuple[str | None, ...]) -> list[Segment]:
    """Segments ``names`` between ``bounds`` (the starts of the second, third, ... segment; a None bound, an event
    that never came, ends the list there) over ``n`` frames; empty segments are left out."""
    starts, ends = [0], []
    for b in bounds:
        if b is None:
            break
        ends.append(b)
        starts.append(b)
    ends.append(n)
    return [Segment(name, s, e, a) for name, s, e, a in zip(names, starts, ends, anchors, strict=False) if e > s]


class Segmentation:
    """The base: no anchors, every scene alike, actions kept. Subclasses define ``observe`` and ``split``."""

    def observe(self, env) -> dict[str, float]:
        raise NotImplementedError

    def split(self, trace: dict[str, np.ndarray]) -> list[Segment]:
        raise NotImplementedError

    def anchors(self, env) -> dict[str, np.ndarray]:
        return {}

    def scene(self, env) -> dict:
        return {}

    def distance(self, a: dict, b: dict) -> float:
        return 0.0

    def adapt(self, actions: np.ndarray, segments: list[Segment], source: dict, scene: dict, env) -> np.ndarray:
        return actions


class PickUpSegmentation(Segmentation):
    """Reach, grasp, lift (HandGrasp, HandPick; HandRelocate adds a target): the reach and the grasp follow the
    object, the lift too. The wearers grip every object palm down whatever its yaw (recorder/demonstrator), so
    the object's frame is its position: a transform turning with the yaw would turn the palm away from the grip the
    person chose. A source serves a scene with the same shape; the nearest in size is taken (its grasp
    posture was shaped for it)."""

    names: tuple[str, ...] = ("reach", "grasp", "lift")

    def __init__(self, position_weight: float = 0.0):
        self.position_weight = position_weight  # a reach from a fixed home: prefer a source reaching the same way

    def observe(self, env) -> dict[str, float]:
        pose, start = env.object_pose(), env.object_start
        return {"touching": float(env.hand_contacts(env.object_geom)), "rise": float(pose[2] - start[2])}

    def split(self, trace: dict[str, np.ndarray]) -> list[Segment]:
        n = len(trace["touching"])
        touch = first(trace["touching"] > 0)
        lift = first(trace["rise"] > LIFT_M, touch or 0) if touch is not None else None
        return cut(self.names, [touch, lift], n, ("object",) * 3)

    def anchors(self, env) -> dict[str, np.ndarray]:
        return {"object": env.object_pose()[:3].copy()}

    def scene(self, env) -> dict:
        return {"shape": env.object_shape, "half_m": [float(x) for x in env.object_half],
                "position_m": [float(x) for x in env.object_start[:2]]}  # fmt: skip

    def distance(self, a: dict, b: dict) -> float:
        other = OTHER_SHAPE if a["shape"] != b["shape"] else 0.0  # taken only when no source has the shape
        size = other + float(np.abs(np.subtract(a["half_m"], b["half_m"])).sum())
        return size + self.position_weight * float(np.linalg.norm(np.subtract(a["position_m"], b["position_m"])))
