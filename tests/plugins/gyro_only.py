"""A fusion filter from outside the package: integrate the gyro alone (docs/fusion.md, "Adding a filter")."""

from dataclasses import dataclass

from numba import njit

from recorder.fusion import register_filter
from recorder.fusion.base import Filter
from recorder.fusion.kernels import _exp, _mul, _normalize


@dataclass
class GyroOnlySettings:
    scale: float = 1.0  # a gyro scale factor, to show a setting


@njit(cache=True)
def step(q, bias, state, gyro, accel, dt, mask, params):
    for i in range(q.shape[0]):
        if mask[i]:
            h = params[0] * dt[i]
            rw, rx, ry, rz = _exp(gyro[i, 0] * h, gyro[i, 1] * h, gyro[i, 2] * h)
            q[i, 0], q[i, 1], q[i, 2], q[i, 3] = _normalize(*_mul(q[i, 0], q[i, 1], q[i, 2], q[i, 3], rw, rx, ry, rz))


@register_filter("gyro_only", settings=GyroOnlySettings, step=step, parent_share=0.5)
class GyroOnlyFilter(Filter):
    def __init__(self, n: int = 12, settings: GyroOnlySettings | None = None):
        super().__init__(n)
        self.settings = settings or GyroOnlySettings()

    def params(self) -> tuple:
        return (float(self.settings.scale),)
