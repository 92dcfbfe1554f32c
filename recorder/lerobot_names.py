"""The names gloverec_sim and gloverec_glove give LeRobot for a task's elements (envs/tasks state_names and
action_names), and back.

LeRobot tells what a scalar is by its name's suffix, ``.pos`` (a position) or ``.vel`` (a velocity), and
lerobot-rollout hands a policy only those (lerobot/rollout/context.py). So an element that is a position gets
``.pos``: every action element (the actuators' position targets, the palm's rotation and position targets), the
palm's and an object's position and orientation (quaternion components: the coordinates MuJoCo's qpos holds for
a free body), a goal's joint angles, a knob's angle. An element that is neither (a size, a flag, a count) keeps its
name: lerobot-record stores it, lerobot-rollout drops it. Datasets recorded before these names (plain ``palm.x``,
actuator names) read back the same: ``gloverec_state_name`` / ``gloverec_action_name`` are the identity on them.
"""

from __future__ import annotations

POS, VEL = ".pos", ".vel"
# the last part of a task element's name that makes it a position: a coordinate, a quaternion component, an angle
COORDINATES = frozenset({"x", "y", "z", "qw", "qx", "qy", "qz", "angle"})


def is_position(name: str) -> bool:
    """A gloverec state element (envs/tasks state_names) that is a position but not named so: a goal's joint
    angle (``goal.*``) or a coordinate of the palm, an object or a target."""
    return not name.endswith((POS, VEL)) and (name.startswith("goal.") or name.rpartition(".")[2] in COORDINATES)


def lerobot_state_name(name: str) -> str:
    return f"{name}{POS}" if is_position(name) else name


def lerobot_action_name(name: str) -> str:
    return f"{name}{POS}"


def gloverec_state_name(name: str) -> str:
    """The task's name of a dataset's state element, either naming."""
    base = name.removesuffix(POS)
    return base if base != name and is_position(base) else name


def gloverec_action_name(name: str) -> str:
    return name.removesuffix(POS)


def gloverec_names(names: dict) -> dict:
    """{feature: element names} of a dataset or checkpoint in the tasks' naming (observation.state, action)."""
    to_ours = {"observation.state": gloverec_state_name, "action": gloverec_action_name}
    return {k: [to_ours[k](n) for n in v] if k in to_ours and v else v for k, v in names.items()}
