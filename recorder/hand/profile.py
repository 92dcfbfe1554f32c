"""A wearer's hand profile: hand length and breadth, optionally measured bone lengths per finger; the HandSize
that forward kinematics, retargeting and the live view's human hand use for that wearer.

Profiles are stored with the glove calibrations, one per wearer: ``<calibration dir>/wearers/<name>.json``
(recorder.paths.calibration_dir: --dir, $GLOVEREC_CALIBRATION_DIR or datasets/calibration). `gloverec calibrate
--wearer NAME` writes one from measurements (--hand-length, --hand-breadth) or estimates the finger proportions
from its pinch step (recorder/hand/pinch.py); `--wearer NAME` on record and view selects it, and a recording
keeps the profile it was made with (meta/gloverec/hand_profile.json, the session log's metadata).

A missing profile, a damaged file or a hand no adult has (a length outside 120-250 mm, a breadth outside 55-130
mm or 0.33-0.62 of the length, a bone outside 0.6-1.5 times its proportional length) is one line (ConfigError).
"""

from __future__ import annotations

import json
import re
import time
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Annotated, Literal

from recorder import config
from recorder.config import STRICT, ConfigError, Positive
from recorder.hand.kinematics import REFERENCE_BREADTH_MM, REFERENCE_LENGTH_MM, HandSize
from recorder.hand.skeleton import FINGER_SEGMENTS, FINGERS
from recorder.paths import calibration_dir

WEARERS = "wearers"  # the profiles' folder inside the calibration folder
LENGTH_MM = (120.0, 250.0)  # adult hands: wrist crease to the middle fingertip
BREADTH_MM = (55.0, 130.0)  # across the metacarpal heads
BREADTH_PER_LENGTH = (0.33, 0.62)
BONE_PER_PROPORTIONAL = (0.6, 1.5)  # a measured bone / its Buchholz length for the same hand length
NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9._-]{0,63}$")


@dataclass(frozen=True)
class HandProfile:
    """One wearer's hand. ``segments_mm``: {finger: (three bone lengths, base to tip, mm)}, fingers without an
    entry keep the proportions of their hand length. ``source``: how it was made (measured by hand, estimated
    from the pinch step, or the reference hand)."""

    __pydantic_config__ = STRICT

    wearer: str
    hand_length_mm: Annotated[float, Positive] = REFERENCE_LENGTH_MM
    hand_breadth_mm: Annotated[float, Positive] | None = None  # None: the reference proportion of the length
    segments_mm: dict[str, tuple[float, float, float]] = field(default_factory=dict)
    source: Literal["measured", "pinch", "reference"] = "measured"
    created: str = ""

    @property
    def breadth_mm(self) -> float:
        if self.hand_breadth_mm is not None:
            return float(self.hand_breadth_mm)
        return self.hand_length_mm * REFERENCE_BREADTH_MM / REFERENCE_LENGTH_MM

    def size(self) -> HandSize:
        """The HandSize of this hand (hashable: kinematic models are cached per size)."""
        return HandSize(
            hand_length_mm=float(self.hand_length_mm),
            hand_breadth_mm=self.breadth_mm,
            segments_mm=tuple(
                (f, tuple(float(v) for v in self.segments_mm[f])) for f in FINGERS if f in self.segments_mm
            ),
        )

    def check(self, where: str = "") -> HandProfile:
        """This profile, if a human hand can have it; else a one-line ConfigError naming what is wrong."""
        at = f"{where or 'hand profile'} ({self.wearer})"
        if not NAME.match(self.wearer):
            raise ConfigError(f"bad wearer name {self.wearer!r}: letters, digits, '.', '_' and '-', at most 64")
        lo, hi = LENGTH_MM
        if not lo <= self.hand_length_mm <= hi:
            raise ConfigError(f"{at}: hand length {self.hand_length_mm:g} mm is not an adult hand's ({lo:g}-{hi:g} mm)")
        b = self.breadth_mm
        lo, hi = BREADTH_MM
        if not lo <= b <= hi:
            raise ConfigError(f"{at}: hand breadth {b:g} mm is not an adult hand's ({lo:g}-{hi:g} mm)")
        lo, hi = BREADTH_PER_LENGTH
        if not lo <= b / self.hand_length_mm <= hi:
            raise ConfigError(
                f"{at}: a {b:g} mm breadth on a {self.hand_length_mm:g} mm hand is not a hand's proportion "
                f"(breadth {lo:g}-{hi:g} of the length)"
            )
        proportional = HandSize(hand_length_mm=float(self.hand_length_mm)).lengths() * 1000.0
        lo, hi = BONE_PER_PROPORTIONAL
        for finger, bones in self.segments_mm.items():
            if finger not in FINGERS:
                raise ConfigError(f"{at}: segments_mm.{finger}: unknown finger; valid: {', '.join(FINGERS)}")
            for k, (mm, ref) in enumerate(zip(bones, proportional[list(FINGER_SEGMENTS[finger])])):
                if not lo * ref <= mm <= hi * ref:
                    raise ConfigError(
                        f"{at}: segments_mm.{finger}[{k}]: {mm:g} mm is not a bone of a {self.hand_length_mm:g} mm "
                        f"hand ({lo * ref:.0f}-{hi * ref:.0f} mm)"
                    )
        return self

    def as_dict(self) -> dict:
        d = asdict(self)
        d["segments_mm"] = {f: list(v) for f, v in self.segments_mm.items()}
        return d


def reference_profile(wearer: str = "reference") -> HandProfile:
    """The 190 mm hand every robot is fitted to (HandSize())."""
    return HandProfile(wearer, source="reference")


def profile_from_dict(values: dict, where: str) -> HandProfile:
    """A profile from its stored mapping (a file, a dataset's metadata), typed and checked: one-line errors."""
    if not isinstance(values, dict):
        raise ConfigError(f"{where}: expected a hand profile mapping, got {type(values).__name__}")
    return config.build(HandProfile, values, where).check(where)


def profile_path(wearer: str, folder=None) -> Path:
    if not NAME.match(wearer or ""):
        raise ConfigError(f"bad wearer name {wearer!r}: letters, digits, '.', '_' and '-', at most 64")
    return calibration_dir(folder) / WEARERS / f"{wearer}.json"


def wearer_names(folder=None) -> tuple[str, ...]:
    return tuple(sorted(p.stem for p in (calibration_dir(folder) / WEARERS).glob("*.json")))


def save_profile(profile: HandProfile, folder=None) -> Path:
    """Check and write the profile (atomically) where ``load_profile`` finds it; returns the path."""
    profile.check()
    if not profile.created:
        profile = replace(profile, created=time.strftime("%Y-%m-%dT%H:%M:%S%z"))
    path = profile_path(profile.wearer, folder)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_suffix(".tmp")
        tmp.write_text(json.dumps(profile.as_dict(), indent=1) + "\n")
        tmp.replace(path)
    except OSError as exc:
        raise ConfigError(f"cannot save the hand profile {path}: {exc.strerror or exc}") from None
    return path


def load_profile(wearer: str, folder=None) -> HandProfile:
    """The saved profile of ``wearer``; none saved, or a damaged or impossible one: one-line ConfigError."""
    path = profile_path(wearer, folder)
    if not path.is_file():
        known = wearer_names(folder)
        raise ConfigError(
            f"no hand profile for wearer {wearer!r} in {path.parent} (known: {', '.join(known) or 'none'}); "
            f"make one: gloverec calibrate --wearer {wearer} --hand-length MM --hand-breadth MM"
        )
    try:
        values = json.loads(path.read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise ConfigError(f"cannot read the hand profile {path}: {str(exc).splitlines()[0]}") from None
    profile = profile_from_dict(values, str(path))
    if profile.wearer != wearer:
        raise ConfigError(f"{path} holds the hand profile of {profile.wearer!r}, not {wearer!r}")
    return profile


def measured_profile(wearer: str, length_mm=None, breadth_mm=None, folder=None) -> HandProfile:
    """``wearer``'s profile with new measurements: what is not given is kept from their saved profile (if any,
    measured segments dropped when the length changes), else the reference length and proportional breadth."""
    path = profile_path(wearer, folder)
    old = load_profile(wearer, folder) if path.is_file() else None
    length = length_mm if length_mm is not None else old.hand_length_mm if old is not None else REFERENCE_LENGTH_MM
    breadth = breadth_mm if breadth_mm is not None else old.hand_breadth_mm if old is not None else None
    segments = dict(old.segments_mm) if old is not None and old.hand_length_mm == length else {}
    if segments:
        source = old.source
    elif length_mm is not None or breadth_mm is not None or (old is not None and old.source != "reference"):
        source = "measured"
    else:  # nothing measured, ever: the reference hand under the wearer's name (the pinch step may add to it)
        source = "reference"
    return HandProfile(wearer, float(length), breadth, segments, source).check()


def segments_from(profile: HandProfile, factors) -> HandProfile:
    """``profile`` with the finger lengths the pinch step estimated: length factors (5,), thumb first, against
    the proportions of its hand length."""
    proportional = HandSize(hand_length_mm=float(profile.hand_length_mm)).lengths() * 1000.0
    segments = {
        f: tuple(round(float(v), 1) for v in k * proportional[list(FINGER_SEGMENTS[f])])
        for f, k in zip(FINGERS, factors)
    }
    return replace(profile, segments_mm=segments, source="pinch", created="").check()


def wearer_profile(wearer: str | None, folder=None) -> HandProfile:
    """``wearer``'s saved profile, or the reference hand when no wearer is named."""
    return reference_profile() if wearer is None else load_profile(wearer, folder)
