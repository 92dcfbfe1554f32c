"""The tracked wrist in the live views (issue 24): where the wrist source puts the palm, how well it is tracked,
and whether the palm target is pressed against the workspace's bounds (``HandEnv.base_bounds``, which the
action's base position is clipped to).

What records (`gloverec record`, `gloverec view --wrist`) puts the fused pose in the frame (``ViewFrame.wrist``)
and ``status(...)`` in its status as ``wrist``:

    state          tracked | catching up (the marker is back; the wrist returns to it at a limited speed) |
                   lost (held where it was: no tracked frame for longer than the fusion's ``lost_after_s``) |
                   waiting (between episodes: the next one's start zeroes the wrist)
    source         marker | udp | scripted (a demonstrator's wrist, always tracked): what lost it, for the guidance
    tracked_share  the share of the frames so far (the episode's, the view's scene's) that were tracked
    age_s          since the last tracked frame
    edge           the sides of the workspace the palm target is beyond, so clipped to: "x+", "z-", ...

Every view draws it (recorder/view/scene.py) and says it (recorder/view/overlay.py). Without a tracked wrist the
status has no ``wrist`` and the views look as they did.
"""

from __future__ import annotations

import numpy as np

from recorder.wrist.fusion import FusedWrist, FusionConfig


def state_of(wrist: FusedWrist, lost_after_s: float = FusionConfig.lost_after_s) -> str:
    """tracked, catching up or lost (FusedWrist.tracked is False for both of the last: the age tells them apart)."""
    if wrist.tracked:
        return "tracked"
    return "lost" if wrist.age_s > lost_after_s else "catching up"


def edges(position, bounds) -> list[str]:
    """The sides of the box ``bounds`` (lo, hi) that ``position`` is beyond: "x-", "x+", ... (none: inside)."""
    lo, hi = (np.asarray(b, float) for b in bounds)
    p = np.asarray(position, float)
    return [f"{axis}{'-' if p[i] < lo[i] else '+'}" for i, axis in enumerate("xyz") if not lo[i] <= p[i] <= hi[i]]


def status(wrist: FusedWrist, bounds, untracked: int, frames: int, source: str) -> dict:
    """The status' ``wrist``: ``untracked`` of ``frames`` so far were not tracked; ``source``: a WristConfig's kind."""
    return {
        "state": state_of(wrist),
        "source": source,
        "tracked_share": 1.0 - untracked / max(frames, 1),
        "age_s": float(wrist.age_s),
        "edge": edges(wrist.position, bounds),
    }


def waiting(source: str) -> dict:
    """The status' ``wrist`` between episodes: no pose until the next episode's start zeroes it."""
    return {"state": "waiting", "source": source, "edge": []}
