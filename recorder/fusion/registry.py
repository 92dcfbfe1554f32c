"""Filters by name: ``make_filter("complementary", static_gain=0.01)``. A new filter is one new file (settings
dataclass + Filter subclass), its step and block kernels in kernels.py, one line here, and for HostFusion a kind
in pipeline.py's ``run``."""

from __future__ import annotations

import dataclasses

from recorder.fusion.base import Filter
from recorder.fusion.complementary import ComplementaryFilter, ComplementarySettings
from recorder.fusion.inertial import InertialFilter, InertialSettings
from recorder.fusion.madgwick import MadgwickFilter, MadgwickSettings
from recorder.fusion.mahony import MahonyFilter, MahonySettings
from recorder.fusion.relative import RelativeFilter, RelativeSettings

FILTERS = {
    "inertial": (InertialFilter, InertialSettings),  # the glove's filter (firmware), low-pass in a non-turning frame
    "complementary": (ComplementaryFilter, ComplementarySettings),  # thesis §3.5, the firmware's filter
    "mahony": (MahonyFilter, MahonySettings),  # Santaera et al. Algorithm 1
    "relative": (RelativeFilter, RelativeSettings),  # Santaera et al. Algorithm 2
    "madgwick": (MadgwickFilter, MadgwickSettings),
}


def settings_for(name: str, **settings):
    """The settings dataclass of filter ``name`` with ``settings`` overriding its defaults."""
    if name not in FILTERS:
        raise ValueError(f"unknown filter {name!r}; valid filters: {', '.join(FILTERS)}")
    cls = FILTERS[name][1]
    known = {f.name for f in dataclasses.fields(cls)}
    unknown = sorted(set(settings) - known)
    if unknown:
        raise ValueError(
            f"unknown setting(s) {', '.join(unknown)} for filter {name!r}; valid settings: {', '.join(sorted(known))}"
        )
    return cls(**settings)


def make_filter(name: str, n: int = 12, **settings) -> Filter:
    """A filter for ``n`` IMUs by name (ValueError listing the valid names and settings otherwise)."""
    config = settings_for(name, **settings)
    return FILTERS[name][0](n, config)
