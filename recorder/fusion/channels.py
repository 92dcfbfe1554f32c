"""A glove's channel map: the software fix for IMUs wired to the wrong multiplexer channel or glued turned about
their normal, found by `gloverec doctor` and saved with ``--fix`` beside the calibration
(``channels_XXXXXXXX.json``). Host fusion applies it to every raw frame before anything else (calibration
included), so a glove with swapped cables needs no re-soldering and a turned IMU no re-gluing.

``order[s]``: the raw index whose readings belong to IMU slot s (the identity for a glove built right);
``turns[s]``: quarter turns that bring slot s's sensor axes back onto its segment's (0 for a glove built right).
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from recorder.hand.skeleton import N_IMUS
from recorder.paths import write_atomic


def quarter_turns(vectors, turns: int) -> np.ndarray:
    """int16 vectors (..., 3) turned by ``turns`` quarter turns about z: each (x, y) -> (y, -x), exactly
    (-32768 negated saturates to 32767). A sensor glued turned by k quarter turns reads its segment's vectors
    turned k times; turning them 4 - k more times undoes it."""
    v = np.asarray(vectors, np.int32)
    x, y, z = v[..., 0], v[..., 1], v[..., 2]
    for _ in range(int(turns) % 4):
        x, y = y, -x
    return np.clip(np.stack((x, y, z), axis=-1), -32768, 32767).astype(np.int16)


@dataclass(frozen=True)
class ChannelMap:
    glove_id: int = 0
    order: tuple[int, ...] = tuple(range(N_IMUS))
    turns: tuple[int, ...] = (0,) * N_IMUS
    note: str = ""  # what the doctor found
    created: str = field(default="", compare=False)

    def __post_init__(self):
        if sorted(self.order) != list(range(N_IMUS)) or len(self.turns) != N_IMUS:
            raise ValueError(f"a channel map holds a permutation of 0-{N_IMUS - 1} and {N_IMUS} quarter turns")

    @property
    def identity(self) -> bool:
        return list(self.order) == list(range(N_IMUS)) and not any(t % 4 for t in self.turns)

    def apply_raw(self, raw: np.ndarray, ok_mask: int) -> tuple[np.ndarray, int]:
        """Readings (12, 7) or (T, 12, 7) and ok mask(s) in slot order."""
        raw = np.asarray(raw)[..., list(self.order), :].copy()
        for s, k in enumerate(self.turns):
            if k % 4:
                raw[..., s, 0:3] = quarter_turns(raw[..., s, 0:3], k)
                raw[..., s, 3:6] = quarter_turns(raw[..., s, 3:6], k)
        bits = np.asarray(ok_mask, np.int64)
        mask = sum(((bits >> src) & 1) << s for s, src in enumerate(self.order))
        return raw, (int(mask) if np.ndim(mask) == 0 else mask)

    def apply(self, frame):
        """A RawFrame in slot order (the same frame object for the identity map)."""
        if self.identity:
            return frame
        data, mask = self.apply_raw(frame.data, frame.ok_mask)
        return replace(frame, data=data, ok_mask=mask)

    def path(self, folder) -> Path:
        return Path(folder) / f"channels_{self.glove_id:08x}.json"

    def to_json(self) -> str:
        return json.dumps({"glove_id": self.glove_id, "order": list(self.order), "turns": list(self.turns),
                           "note": self.note, "created": self.created}, indent=1)  # fmt: skip

    @classmethod
    def from_json(cls, text: str) -> ChannelMap:
        d = json.loads(text)
        return cls(int(d["glove_id"]), tuple(int(i) for i in d["order"]), tuple(int(k) for k in d["turns"]),
                   str(d.get("note", "")), str(d.get("created", "")))  # fmt: skip

    def save(self, folder) -> Path:
        return write_atomic(self.path(folder), self.to_json())


def load_channel_map(folder, glove_id: int) -> ChannelMap | None:
    """The glove's saved channel map, None when it has none; a damaged file raises ValueError (OSError unreadable)."""
    p = ChannelMap(glove_id=int(glove_id)).path(folder)
    if not p.exists():
        return None
    m = ChannelMap.from_json(p.read_text())
    if m.glove_id != int(glove_id):
        raise ValueError(f"{p} holds the channel map of glove {m.glove_id:08x}")
    return m
