"""The inputs a policy reads, by name: what `gloverec train --inputs` takes and a checkpoint records.

    state        observation.state: the robot's own joint positions and velocities (and palm pose)
    environment  the simulator's hidden state: observation.environment_state, and the task's values a
                 lerobot-record dataset (gloverec_sim) stores inside observation.state (goal.*, object.*, ...)
    images       every camera, observation.images.*; images.CAMERA for one
    task         the instruction (the dataset's ``task`` string), through a learned embedding per instruction

The default is what a deployed robot has: state, images and task, of those the dataset carries. The split of
observation.state goes by element name: a robot's own elements are its joints' ``*.pos`` / ``*.vel`` and the
palm's ``palm.*`` (envs/tasks/base.py state_names); every other element is the task's. A gloverec_sim dataset's
names are read in the tasks' naming first (``goal.x.pos`` is the task's ``goal.x``: recorder/lerobot_names.py).
"""

from __future__ import annotations

from recorder.lerobot_names import gloverec_state_name

NAMES = ("state", "environment", "images", "task")
ROBOT = ("state", "images", "task")  # what a deployed robot has: the default
IMAGE_PREFIX = "observation.images."


def parse(text: str | list | tuple | None) -> tuple[str, ...] | None:
    """``"state,images,task"`` (or a list) as a tuple of checked names; None stays None (the default)."""
    if text is None:
        return None
    items = [s.strip() for s in (text.split(",") if isinstance(text, str) else text) if str(s).strip()]
    bad = [s for s in items if s not in NAMES and not (s.startswith("images.") and len(s) > len("images."))]
    if bad:
        raise ValueError(f"unknown input {bad[0]!r}; valid: {', '.join(NAMES)}, images.CAMERA")
    if not items:
        raise ValueError(f"no inputs given; valid: {', '.join(NAMES)}, images.CAMERA")
    return tuple(dict.fromkeys(items))


def task_instructions(root) -> list[str]:
    """Every instruction the task a dataset was recorded in can draw (our sidecar names the task and robot; the
    task registry's ``instructions``), or [] for a dataset without our sidecar (lerobot-record's)."""
    import envs  # MuJoCo: only when a policy is made
    from policies.data import recorded_with

    first = recorded_with(root)
    if first.get("env_task") not in envs.task_names() or not first.get("robot"):
        return []
    try:
        env = envs.make(first["env_task"], first["robot"])
    except ValueError:  # a robot config no longer here: the training set's instructions only
        return []
    try:
        return list(env.unwrapped.instructions())
    finally:
        env.close()


def is_robot_state(name: str) -> bool:
    """An element of observation.state the robot measures itself (not a task value stored beside it)."""
    name = gloverec_state_name(name)
    return name.startswith("palm.") or name.endswith((".pos", ".vel"))


def state_indices(names: list[str] | None, inputs: tuple[str, ...]) -> list[int] | None:
    """The elements of observation.state the inputs keep (None: all of them, or the names are unknown)."""
    if not names:
        return None
    keep = [
        i
        for i, n in enumerate(names)
        if ("state" in inputs and is_robot_state(n)) or ("environment" in inputs and not is_robot_state(n))
    ]
    return None if len(keep) == len(names) else keep


def reads_image(key: str, inputs: tuple[str, ...]) -> bool:
    return "images" in inputs or f"images.{key.removeprefix(IMAGE_PREFIX)}" in inputs


def missing(inputs: tuple[str, ...], features: dict) -> list[str]:
    """The named inputs a dataset's features (info.json's) do not carry, each as a phrase."""
    out = []
    state = features.get("observation.state", {}).get("names") or []
    has_env = "observation.environment_state" in features or any(not is_robot_state(n) for n in state)
    cams = [k.removeprefix(IMAGE_PREFIX) for k in features if k.startswith(IMAGE_PREFIX)]
    for name in inputs:
        if name == "state" and "observation.state" not in features:
            out.append("observation.state")
        elif name == "environment" and not has_env:
            out.append("environment state")
        elif name == "images" and not cams:
            out.append("cameras (record with --cameras)")
        elif name.startswith("images.") and name.removeprefix("images.") not in cams:
            out.append(f"camera {name.removeprefix('images.')} (it has {', '.join(cams) or 'none'})")
    return out
