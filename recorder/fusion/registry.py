"""The filter registry: a filter is one module (recorder/fusion/<name>.py, or a plugin's: recorder/plugins.py)
holding its settings dataclass, its ``Filter`` subclass with its state arrays, and its numba step kernel, and
registering them with ``@register_filter(name, ...)``. HostFusion, `gloverec calibrate --config`, the fusion
configs (configs/fusion/*.yaml) and the benchmarks find filters here by name; docs/fusion.md, "Adding a filter",
is a worked example.

Every step kernel has one signature, ``step(q, bias, state, gyro, accel, dt, mask, params)``: q (n, 4) and bias
(n, 3) the orientations and the filter's own gyro-bias estimate (zeros for filters without one), ``state`` the
tuple of the filter's other arrays (``Filter.kernel_state()``), one sample of every IMU (gyro, accel (n, 3), dt
(n,), mask (n,) bool) and ``params`` (the settings as a float64 array, ``Filter.params()``). The host pipeline and
the block loop of each filter are generated around that step (recorder/fusion/dispatch.py), so nothing is written
per filter but its module.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any

from recorder.plugins import load_plugins


@dataclass(frozen=True)
class FilterSpec:
    name: str
    filter: type  # the Filter subclass
    settings: type  # its settings dataclass
    step: Any  # its numba step kernel, the signature above
    parent_share: float = 0.5  # share of a joint's heading error corrected on the parent's side (FusionConfig)
    heading_bias_rate: float = 1.0  # 1/s^2: joint-constraint heading feedback into the bias tracker
    own_bias: bool = False  # the filter estimates its gyro bias itself: the host's tracker then uses no gravity


_FILTERS: dict[str, FilterSpec] = {}


def register_filter(name: str, *, settings: type, step, **defaults):
    """Class decorator: register a Filter subclass as filter ``name`` with its settings dataclass, its step
    kernel and the host's per-filter defaults (FilterSpec's fields)."""

    def register(cls: type) -> type:
        old = _FILTERS.get(name)
        if old is not None and old.filter.__qualname__ != cls.__qualname__:
            raise ValueError(f"filter {name!r} is registered already (by {old.filter.__module__})")
        cls.name = name
        cls.spec = _FILTERS[name] = FilterSpec(name, cls, settings, step, **defaults)
        return cls

    return register


def filter_names() -> tuple[str, ...]:
    _load()
    return tuple(_FILTERS)


def get_filter(name: str) -> FilterSpec:
    """Filter ``name``; an unknown one: ValueError listing the registered ones (config turns it into one line)."""
    _load()
    if name not in _FILTERS:
        raise ValueError(f"unknown filter {name!r}; valid filters: {', '.join(_FILTERS)}")
    return _FILTERS[name]


def settings_for(name: str, **settings):
    """The settings dataclass of filter ``name`` with ``settings`` overriding its defaults."""
    cls = get_filter(name).settings
    known = {f.name for f in dataclasses.fields(cls)}
    unknown = sorted(set(settings) - known)
    if unknown:
        raise ValueError(
            f"unknown setting(s) {', '.join(unknown)} for filter {name!r}; valid settings: {', '.join(sorted(known))}"
        )
    return cls(**settings)


def make_filter(name: str, n: int = 12, **settings):
    """A filter for ``n`` IMUs by name (ValueError listing the valid names and settings otherwise)."""
    config = settings_for(name, **settings)
    return get_filter(name).filter(n, config)


def _load() -> None:
    import recorder.fusion  # noqa: F401  (the built-in filters register when the package loads)

    load_plugins()
