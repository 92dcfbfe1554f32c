"""The fusion's one implementation: numba kernels for every filter's update step (and the bias tracker's), each
over all IMUs of one sample, and the block loops over T samples built on the same step functions. The filter
classes (recorder/fusion/complementary.py, mahony.py, madgwick.py, relative.py, bias.py) hold the settings and
the state and document the maths; ``update`` calls a step kernel, ``filter_block`` the block loop, and the host
pipeline (recorder/fusion/pipeline.py) the step kernels. Every kernel updates the state arrays in place (C
contiguous float64, int64 for the median heads and counts, bool masks) and a block loop writes q after each
sample to out. ``NUMBA_DISABLE_JIT=1`` runs the same code as plain Python (for a debugger).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=True)
def _normalize(w, x, y, z):
    n = math.sqrt(w * w + x * x + y * y + z * z)
    return w / n, x / n, y / n, z / n


@njit(cache=True)
def _mul(aw, ax, ay, az, bw, bx, by, bz):
    return (
        aw * bw - ax * bx - ay * by - az * bz,
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
    )


@njit(cache=True)
def _rotate(w, x, y, z, vx, vy, vz):
    """q v q* as quat.rotate: v + w t + u x t with t = 2 u x v."""
    tx = 2.0 * (y * vz - z * vy)
    ty = 2.0 * (z * vx - x * vz)
    tz = 2.0 * (x * vy - y * vx)
    return (vx + w * tx + (y * tz - z * ty), vy + w * ty + (z * tx - x * tz), vz + w * tz + (x * ty - y * tx))


@njit(cache=True)
def _exp(rx, ry, rz):
    """quat.from_rotvec: (cos(a/2), r * 0.5 sinc(a / 2pi))."""
    a = math.sqrt(rx * rx + ry * ry + rz * rz)
    if a < 1e-8:
        s = 0.5 - a * a / 48.0
    else:
        s = math.sin(0.5 * a) / a
    return math.cos(0.5 * a), rx * s, ry * s, rz * s


@njit(cache=True)
def _gain_factor(norm, t1, t2):
    em = abs(norm - 1.0)
    if em <= t1:
        return 1.0
    if em < t2:
        return (t2 - em) / (t2 - t1)
    return 0.0  # also NaN


@njit(cache=True)
def gain_factors(norm, t1, t2):
    """_gain_factor for every value of the 1-D array norm."""
    out = np.empty(norm.shape[0])
    for k in range(norm.shape[0]):
        out[k] = _gain_factor(norm[k], t1, t2)
    return out


@njit(cache=True)
def _insert(v, n, x):
    """Insert x into the sorted v[:n] (room for n + 1)."""
    j = n
    while j > 0 and v[j - 1] > x:
        v[j] = v[j - 1]
        j -= 1
    v[j] = x


@njit(cache=True)
def _remove(v, n, x):
    """Remove one value equal to x from the sorted v[:n]."""
    j = 0
    while j < n - 1 and v[j] != x:
        j += 1
    while j < n - 1:
        v[j] = v[j + 1]
        j += 1


@njit(cache=True)
def _sorted_windows(buf, count):
    """Per IMU and axis, the samples held in sorted order (n, 3, window)."""
    n, window = buf.shape[0], buf.shape[1]
    srt = np.empty((n, 3, window))
    for i in range(n):
        for c in range(3):
            for k in range(count[i]):
                _insert(srt[i, c], k, buf[i, k, c])
    return srt


@njit(cache=True)
def _push(buf, head, count, i, x):
    """Write sample x (3,) at IMU i's buffer head; the head advances modulo the window, the count grows to it."""
    window = buf.shape[1]
    h = head[i]
    for c in range(3):
        buf[i, h, c] = x[c]
    head[i] = (h + 1) % window
    if count[i] < window:
        count[i] += 1


@njit(cache=True)
def _middle(v, m):
    """The median of the sorted v[:m]: the middle value (odd m), the mean of the two middle ones (even m), 0 for
    m = 0."""
    if m == 0:
        return 0.0
    return v[m // 2] if m & 1 else 0.5 * (v[m // 2 - 1] + v[m // 2])


@njit(cache=True)
def median_push(buf, head, count, accel, mask):
    """Push accel (n, 3) into the median windows of the masked IMUs, without filtering."""
    for i in range(buf.shape[0]):
        if mask[i]:
            _push(buf, head, count, i, accel[i])


@njit(cache=True)
def median_value(buf, count):
    """The per-axis medians (n, 3) of the samples held ((0, 0, 0) while a window is empty)."""
    srt = _sorted_windows(buf, count)
    out = np.empty((buf.shape[0], 3))
    for i in range(buf.shape[0]):
        for c in range(3):
            out[i, c] = _middle(srt[i, c], count[i])
    return out


@njit(cache=True)
def complementary_step(q, buf, head, count, gain, srt, a, gyro, accel, dt, mask, static_gain, t1, t2):
    """recorder/fusion/complementary.py, steps 1-8, one sample of every IMU (gyro, accel (n, 3), dt, mask (n,)).
    srt (n, 3, window): each median window kept sorted (from _sorted_windows): a push removes the sample it
    overwrites and inserts the new one, the same values as sorting the buffer; a (3,) scratch."""
    n, window = buf.shape[0], buf.shape[1]
    for i in range(n):
        if not mask[i]:
            continue
        h = head[i]
        m = count[i]
        for c in range(3):
            if m == window:
                _remove(srt[i, c], m, buf[i, h, c])
                _insert(srt[i, c], m - 1, accel[i, c])
            else:
                _insert(srt[i, c], m, accel[i, c])
        _push(buf, head, count, i, accel[i])
        m = count[i]
        for c in range(3):
            a[c] = _middle(srt[i, c], m)
        w, x, y, z = q[i, 0], q[i, 1], q[i, 2], q[i, 3]
        hd = 0.5 * dt[i]
        hx, hy, hz = hd * gyro[i, 0], hd * gyro[i, 1], hd * gyro[i, 2]
        w, x, y, z = _normalize(
            w - hx * x - hy * y - hz * z,
            x + hx * w - hy * z + hz * y,
            y + hx * z + hy * w - hz * x,
            z - hx * y + hy * x + hz * w,
        )
        an = math.sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2])
        alpha = static_gain * _gain_factor(an, t1, t2)
        if alpha > 0.0:
            gx, gy, gz = _rotate(w, x, y, z, a[0] / an, a[1] / an, a[2] / an)
            gn = math.sqrt(gx * gx + gy * gy + gz * gz)
            gx, gy, gz = gx / gn, gy / gn, gz / gn
            if gz < -0.999999:
                ax_, ay_, az_ = 0.0, gz, -gy
                if math.sqrt(ay_ * ay_ + az_ * az_) < 1e-3:
                    ax_, ay_, az_ = -gz, 0.0, gx
                an_ = math.sqrt(ax_ * ax_ + ay_ * ay_ + az_ * az_)
                dw, dx, dy, dz = 0.0, ax_ / an_, ay_ / an_, az_ / an_
            else:
                dw, dx, dy, dz = _normalize(1.0 + gz, gy, -gx, 0.0)
            dw, dx, dy, dz = _normalize((1.0 - alpha) + alpha * dw, alpha * dx, alpha * dy, alpha * dz)
            w, x, y, z = _normalize(*_mul(dw, dx, dy, dz, w, x, y, z))
        q[i, 0], q[i, 1], q[i, 2], q[i, 3] = w, x, y, z
        gain[i] = alpha


@njit(cache=True)
def complementary(q, buf, head, count, gain, gyro, accel, dt, mask, static_gain, t1, t2, out):
    """complementary_step over (T, n) samples; q after each sample into out (T, n, 4)."""
    srt = _sorted_windows(buf, count)
    a = np.empty(3)
    for t in range(gyro.shape[0]):
        complementary_step(q, buf, head, count, gain, srt, a, gyro[t], accel[t], dt[t], mask[t], static_gain, t1, t2)
        out[t] = q


@njit(cache=True)
def _mahony_step(w, x, y, z, b, gx, gy, gz, ax, ay, az, dt, kp, ki, t1, t2, il):
    """One Algorithm 1 step; b (3,) is updated in place; returns the new q."""
    an = math.sqrt(ax * ax + ay * ay + az * az)
    trust = _gain_factor(an, t1, t2)
    ex = ey = ez = 0.0
    if trust > 0.0 and an > 0.0:
        ax, ay, az = ax / an, ay / an, az / an
        vx, vy, vz = _rotate(w, -x, -y, -z, 0.0, 0.0, 1.0)
        ex = trust * (ay * vz - az * vy)
        ey = trust * (az * vx - ax * vz)
        ez = trust * (ax * vy - ay * vx)
    if math.sqrt(ex * ex + ey * ey + ez * ez) < il:
        b[0] -= ki * ex * dt
        b[1] -= ki * ey * dt
        b[2] -= ki * ez * dt
    rw, rx, ry, rz = _exp((gx + kp * ex - b[0]) * dt, (gy + kp * ey - b[1]) * dt, (gz + kp * ez - b[2]) * dt)
    return _normalize(*_mul(w, x, y, z, rw, rx, ry, rz))


@njit(cache=True)
def mahony_step(q, bias, gyro, accel, dt, mask, kp, ki, t1, t2, il):
    """recorder/fusion/mahony.py, steps 1-6, one sample of every IMU."""
    for i in range(q.shape[0]):
        if mask[i]:
            q[i, 0], q[i, 1], q[i, 2], q[i, 3] = _mahony_step(
                q[i, 0],
                q[i, 1],
                q[i, 2],
                q[i, 3],
                bias[i],
                gyro[i, 0],
                gyro[i, 1],
                gyro[i, 2],
                accel[i, 0],
                accel[i, 1],
                accel[i, 2],
                dt[i],
                kp,
                ki,
                t1,
                t2,
                il,
            )


@njit(cache=True)
def mahony(q, bias, gyro, accel, dt, mask, kp, ki, t1, t2, il, out):
    """mahony_step over (T, n) samples; q after each sample into out (T, n, 4)."""
    for t in range(gyro.shape[0]):
        mahony_step(q, bias, gyro[t], accel[t], dt[t], mask[t], kp, ki, t1, t2, il)
        out[t] = q


@njit(cache=True)
def madgwick_step(q, gyro, accel, dt, mask, beta, t1, t2):
    """recorder/fusion/madgwick.py, steps 1-3, one sample of every IMU."""
    for i in range(q.shape[0]):
        if not mask[i]:
            continue
        w, x, y, z = q[i, 0], q[i, 1], q[i, 2], q[i, 3]
        ax, ay, az = accel[i, 0], accel[i, 1], accel[i, 2]
        an = math.sqrt(ax * ax + ay * ay + az * az)
        trust = _gain_factor(an, t1, t2)
        sw = sx = sy = sz = 0.0
        if trust > 0.0 and an > 0.0:
            ax, ay, az = ax / an, ay / an, az / an
            f1 = 2.0 * (x * z - w * y) - ax
            f2 = 2.0 * (w * x + y * z) - ay
            f3 = 1.0 - 2.0 * (x * x + y * y) - az
            sw = -2.0 * y * f1 + 2.0 * x * f2
            sx = 2.0 * z * f1 + 2.0 * w * f2 - 4.0 * x * f3
            sy = -2.0 * w * f1 + 2.0 * z * f2 - 4.0 * y * f3
            sz = 2.0 * x * f1 + 2.0 * y * f2
            sn = math.sqrt(sw * sw + sx * sx + sy * sy + sz * sz)
            if sn > 0.0:
                sw, sx, sy, sz = trust * sw / sn, trust * sx / sn, trust * sy / sn, trust * sz / sn
            else:
                sw = sx = sy = sz = 0.0
        dw, dx, dy, dz = _mul(w, x, y, z, 0.0, gyro[i, 0], gyro[i, 1], gyro[i, 2])
        h = dt[i]
        q[i, 0], q[i, 1], q[i, 2], q[i, 3] = _normalize(
            w + (0.5 * dw - beta * sw) * h,
            x + (0.5 * dx - beta * sx) * h,
            y + (0.5 * dy - beta * sy) * h,
            z + (0.5 * dz - beta * sz) * h,
        )


@njit(cache=True)
def madgwick(q, gyro, accel, dt, mask, beta, t1, t2, out):
    """madgwick_step over (T, n) samples; q after each sample into out (T, n, 4)."""
    for t in range(gyro.shape[0]):
        madgwick_step(q, gyro[t], accel[t], dt[t], mask[t], beta, t1, t2)
        out[t] = q


@njit(cache=True)
def relative_step(
    q,
    rel,
    root_q,
    root_bias,
    bias,
    parents,
    order,
    gyro,
    accel,
    dt,
    mask,
    kp,
    ki,
    root_kp,
    root_ki,
    t1,
    t2,
    il,
    rotate_parent,
):
    """recorder/fusion/relative.py (Algorithm 2, roots by Algorithm 1), one sample of every IMU."""
    n = gyro.shape[0]
    for i in range(n):
        p = parents[i]
        if p < 0:
            if mask[i]:
                root_q[i, 0], root_q[i, 1], root_q[i, 2], root_q[i, 3] = _mahony_step(
                    root_q[i, 0],
                    root_q[i, 1],
                    root_q[i, 2],
                    root_q[i, 3],
                    root_bias[i],
                    gyro[i, 0],
                    gyro[i, 1],
                    gyro[i, 2],
                    accel[i, 0],
                    accel[i, 1],
                    accel[i, 2],
                    dt[i],
                    root_kp,
                    root_ki,
                    t1,
                    t2,
                    il,
                )
            continue
        if not (mask[i] and mask[p]):
            continue
        w, x, y, z = rel[i, 0], rel[i, 1], rel[i, 2], rel[i, 3]
        cx, cy, cz = accel[i, 0], accel[i, 1], accel[i, 2]
        px, py, pz = accel[p, 0], accel[p, 1], accel[p, 2]
        nc = math.sqrt(cx * cx + cy * cy + cz * cz)
        np_ = math.sqrt(px * px + py * py + pz * pz)
        trust = _gain_factor(1.0 + abs(nc - np_), t1, t2)
        ex = ey = ez = 0.0
        if trust > 0.0 and nc > 0.0 and np_ > 0.0:
            cx, cy, cz = cx / nc, cy / nc, cz / nc
            dx, dy, dz = _rotate(w, -x, -y, -z, px / np_, py / np_, pz / np_)
            ex = trust * (cy * dz - cz * dy)
            ey = trust * (cz * dx - cx * dz)
            ez = trust * (cx * dy - cy * dx)
        h = dt[i]
        if math.sqrt(ex * ex + ey * ey + ez * ez) < il:
            bias[i, 0] -= ki * ex * h
            bias[i, 1] -= ki * ey * h
            bias[i, 2] -= ki * ez * h
        if rotate_parent:
            ox, oy, oz = _rotate(w, -x, -y, -z, gyro[p, 0], gyro[p, 1], gyro[p, 2])
        else:
            ox, oy, oz = gyro[p, 0], gyro[p, 1], gyro[p, 2]
        rw, rx, ry, rz = _exp(
            (gyro[i, 0] - ox + kp * ex - bias[i, 0]) * h,
            (gyro[i, 1] - oy + kp * ey - bias[i, 1]) * h,
            (gyro[i, 2] - oz + kp * ez - bias[i, 2]) * h,
        )
        rel[i, 0], rel[i, 1], rel[i, 2], rel[i, 3] = _normalize(*_mul(w, x, y, z, rw, rx, ry, rz))
    relative_compose(q, rel, root_q, root_bias, bias, parents, order)


@njit(cache=True)
def relative_compose(q, rel, root_q, root_bias, bias, parents, order):
    """q down the IMU tree in ``order`` (parents first): a root's own (and its bias), q_c = q_p (x) r_c."""
    for k in range(order.shape[0]):
        i = order[k]
        p = parents[i]
        if p < 0:
            for c in range(4):
                q[i, c] = root_q[i, c]
            for c in range(3):
                bias[i, c] = root_bias[i, c]
        else:
            q[i, 0], q[i, 1], q[i, 2], q[i, 3] = _mul(
                q[p, 0], q[p, 1], q[p, 2], q[p, 3], rel[i, 0], rel[i, 1], rel[i, 2], rel[i, 3]
            )


@njit(cache=True)
def relative(
    q,
    rel,
    root_q,
    root_bias,
    bias,
    parents,
    order,
    gyro,
    accel,
    dt,
    mask,
    kp,
    ki,
    root_kp,
    root_ki,
    t1,
    t2,
    il,
    rotate_parent,
    out,
):
    """relative_step over (T, n) samples; q after each sample into out (T, n, 4)."""
    for t in range(gyro.shape[0]):
        relative_step(
            q,
            rel,
            root_q,
            root_bias,
            bias,
            parents,
            order,
            gyro[t],
            accel[t],
            dt[t],
            mask[t],
            kp,
            ki,
            root_kp,
            root_ki,
            t1,
            t2,
            il,
            rotate_parent,
        )
        out[t] = q


@njit(cache=True)
def bias_step(b, still_for, gyro, accel, q, trust, dt, mask, bp, use_gravity):
    """recorder/fusion/bias.py sources 1 and 2, one sample of every IMU: gyro (n, 3) with the static bias but not
    b removed, q (n, 4) the filter's new orientations, trust (n,), dt (n,), mask (n,); bp: BiasSettings (ki,
    still_rate, still_time_s, still_tau_s, max_bias). b and still_for are updated in place."""
    for i in range(b.shape[0]):
        r0, r1, r2 = gyro[i, 0] - b[i, 0], gyro[i, 1] - b[i, 1], gyro[i, 2] - b[i, 2]
        if use_gravity and bp[0] > 0.0 and mask[i]:
            ax, ay, az = accel[i, 0], accel[i, 1], accel[i, 2]
            an = math.sqrt(ax * ax + ay * ay + az * az)
            if an > 0.0:
                ax, ay, az = ax / an, ay / an, az / an
            else:
                ax = ay = az = 0.0
            vx, vy, vz = _rotate(q[i, 0], -q[i, 1], -q[i, 2], -q[i, 3], 0.0, 0.0, 1.0)
            k = bp[0] * trust[i] * dt[i]
            b[i, 0] -= k * (ay * vz - az * vy)
            b[i, 1] -= k * (az * vx - ax * vz)
            b[i, 2] -= k * (ax * vy - ay * vx)
        still = mask[i] and max(abs(r0), abs(r1), abs(r2)) < bp[1] and trust[i] >= 1.0
        still_for[i] = still_for[i] + dt[i] if still else 0.0
        if still and still_for[i] >= bp[2]:
            k = min(dt[i] / bp[3], 1.0)
            b[i, 0] += k * r0
            b[i, 1] += k * r1
            b[i, 2] += k * r2
        for c in range(3):
            b[i, c] = min(max(b[i, c], -bp[4]), bp[4])


@njit(cache=True)
def bias_heading(b, q, seen, gain, mask):
    """recorder/fusion/bias.py source 3: b -= gain seen for the masked IMUs, seen (n, 3) mapped from the world
    into each IMU's axes by q (n, 4); gain (n,)."""
    for i in range(b.shape[0]):
        if mask[i]:
            ux, uy, uz = _rotate(q[i, 0], -q[i, 1], -q[i, 2], -q[i, 3], seen[i, 0], seen[i, 1], seen[i, 2])
            b[i, 0] -= gain[i] * ux
            b[i, 1] -= gain[i] * uy
            b[i, 2] -= gain[i] * uz


# ------------------------------------------------------------------------------------------------ inertial filter
# recorder/fusion/inertial.py. The twin of the glove's filter (firmware/lib/glove_core/complementary_filter.cpp,
# FilterMode::Inertial): every operation below is the C++ one in the same order (the firmware's normalized()
# multiplies by 1 / norm, its rotate() is v + w t + u x t), so a double build of the core gives the same bits
# (tests/test_fusion_firmware.py). No libm call but sqrt in a step: the emulated Cortex-M7 matches the host too.


@njit(cache=True)
def _unit(w, x, y, z):
    """quaternion.h normalized(): q / |q| as q * (1 / |q|); the identity for a zero or non-finite q."""
    n = math.sqrt(w * w + x * x + y * y + z * z)
    if not (n > 1e-12) or not math.isfinite(n):
        return 1.0, 0.0, 0.0, 0.0
    s = 1.0 / n
    return w * s, x * s, y * s, z * s


@njit(cache=True)
def _exp_half(hx, hy, hz):
    """exp of the rotation whose half-angle vector is h: (cos |h|, sin |h| / |h| h) by their Taylor series to
    |h|^4 (the firmware's exp_half; |h| < 0.1 rad at 100 Hz and 20 rad/s, where the next term is 1e-10)."""
    t = hx * hx + hy * hy + hz * hz
    c = 1.0 - t * (0.5 - t * (1.0 / 24.0))
    s = 1.0 - t * (1.0 / 6.0 - t * (1.0 / 120.0))
    return c, s * hx, s * hy, s * hz


@njit(cache=True)
def _from_gravity(ax, ay, az):
    """Thesis eq. 3.5-3.6 (yaw 0) without trigonometric functions, as complementary_filter.cpp
    attitude_from_gravity: (cos, sin) of half the roll atan2(ay, az) is the direction of (r + az, ay), or of
    (|ay|, +-(r - az)) when az < 0 (r = sqrt(ay^2 + az^2)); of half the pitch atan2(-ax, r) that of (|a| + r, -ax).
    Gravity along x: roll 0; the identity for a zero vector."""
    r = math.sqrt(ay * ay + az * az)
    n = math.sqrt(ax * ax + r * r)
    if not (n > 0.0):
        return 1.0, 0.0, 0.0, 0.0
    cr, sr = 1.0, 0.0
    if r > 0.0:
        neg = math.copysign(1.0, ay) < 0.0
        u = r + az if az >= 0.0 else abs(ay)
        v = ay if az >= 0.0 else ((az - r) if neg else (r - az))
        k = 1.0 / math.sqrt(u * u + v * v)
        cr, sr = u * k, v * k
    u, v = n + r, -ax
    k = 1.0 / math.sqrt(u * u + v * v)
    cp, sp = u * k, v * k
    return cr * cp, sr * cp, cr * sp, -sr * sp


@njit(cache=True)
def _inertial_output(q, qg, qc, i):
    q[i, 0], q[i, 1], q[i, 2], q[i, 3] = _unit(
        *_mul(qc[i, 0], qc[i, 1], qc[i, 2], qc[i, 3], qg[i, 0], qg[i, 1], qg[i, 2], qg[i, 3])
    )


@njit(cache=True)
def _gravity_estimate(lp, i, ramp):
    """The accelerometer low-passed in the almost-inertial frame: y3 + ramp (y2 - y3) (inertial.py step 4)."""
    return (
        lp[i, 2, 0] + ramp * (lp[i, 1, 0] - lp[i, 2, 0]),
        lp[i, 2, 1] + ramp * (lp[i, 1, 1] - lp[i, 2, 1]),
        lp[i, 2, 2] + ramp * (lp[i, 1, 2] - lp[i, 2, 2]),
    )


@njit(cache=True)
def inertial_observe(qg, lp, nobs, accel, mask):
    """recorder/fusion/inertial.py ``observe``: the masked IMUs' low-pass stages become the mean of the samples
    observed since the last update (in the almost-inertial frame)."""
    for i in range(qg.shape[0]):
        if not mask[i]:
            continue
        ax, ay, az = _rotate(qg[i, 0], qg[i, 1], qg[i, 2], qg[i, 3], accel[i, 0], accel[i, 1], accel[i, 2])
        if nobs[i] < 65535:
            nobs[i] += 1
        n = float(nobs[i])
        y0 = lp[i, 0, 0] + (ax - lp[i, 0, 0]) / n
        y1 = lp[i, 0, 1] + (ay - lp[i, 0, 1]) / n
        y2 = lp[i, 0, 2] + (az - lp[i, 0, 2]) / n
        for s in range(3):
            lp[i, s, 0], lp[i, s, 1], lp[i, s, 2] = y0, y1, y2


@njit(cache=True)
def inertial_reset(q, qg, qc, lp, nobs, accel, use_accel, mask, ramp):
    """recorder/fusion/inertial.py ``reset``: attitude from gravity (eq. 3.5-3.6) for the masked IMUs, from accel
    (n, 3) when use_accel (the low-pass stages restart there) or else from the low-passed estimate (the stages
    are kept, re-expressed in the new almost-inertial frame, which is the IMU's own at this moment)."""
    for i in range(qg.shape[0]):
        if not mask[i]:
            continue
        if use_accel:
            for s in range(3):
                lp[i, s, 0], lp[i, s, 1], lp[i, s, 2] = accel[i, 0], accel[i, 1], accel[i, 2]
        else:
            for s in range(3):
                lp[i, s, 0], lp[i, s, 1], lp[i, s, 2] = _rotate(
                    qg[i, 0], -qg[i, 1], -qg[i, 2], -qg[i, 3], lp[i, s, 0], lp[i, s, 1], lp[i, s, 2]
                )
        gx, gy, gz = _gravity_estimate(lp, i, ramp)
        qc[i, 0], qc[i, 1], qc[i, 2], qc[i, 3] = _from_gravity(gx, gy, gz)
        qg[i, 0], qg[i, 1], qg[i, 2], qg[i, 3] = 1.0, 0.0, 0.0, 0.0
        nobs[i] = 0
        _inertial_output(q, qg, qc, i)


@njit(cache=True)
def inertial_step(q, qg, qc, lp, nobs, gyro, accel, dt, mask, tau, ramp):
    """recorder/fusion/inertial.py steps 1-6, one sample of every IMU."""
    for i in range(q.shape[0]):
        if not mask[i]:
            continue
        h = 0.5 * dt[i]
        rw, rx, ry, rz = _exp_half(h * gyro[i, 0], h * gyro[i, 1], h * gyro[i, 2])
        gw, gx, gy, gz = _unit(*_mul(qg[i, 0], qg[i, 1], qg[i, 2], qg[i, 3], rw, rx, ry, rz))
        qg[i, 0], qg[i, 1], qg[i, 2], qg[i, 3] = gw, gx, gy, gz
        a = _rotate(gw, gx, gy, gz, accel[i, 0], accel[i, 1], accel[i, 2])
        k = dt[i] / tau
        if k > 1.0:
            k = 1.0
        for c in range(3):
            lp[i, 0, c] = lp[i, 0, c] + k * (a[c] - lp[i, 0, c])
            lp[i, 1, c] = lp[i, 1, c] + k * (lp[i, 0, c] - lp[i, 1, c])
            lp[i, 2, c] = lp[i, 2, c] + k * (lp[i, 1, c] - lp[i, 2, c])
        nobs[i] = 0
        ex, ey, ez = _gravity_estimate(lp, i, ramp)
        ex, ey, ez = _rotate(qc[i, 0], qc[i, 1], qc[i, 2], qc[i, 3], ex, ey, ez)
        n = math.sqrt(ex * ex + ey * ey + ez * ez)
        if n > 0.0 and math.isfinite(n):
            s = 1.0 / n
            ux, uy, uz = ex * s, ey * s, ez * s
            if 1.0 + uz > 1e-6:
                cw, cx, cy, cz = _unit(1.0 + uz, uy, -ux, 0.0)
                qc[i, 0], qc[i, 1], qc[i, 2], qc[i, 3] = _unit(
                    *_mul(cw, cx, cy, cz, qc[i, 0], qc[i, 1], qc[i, 2], qc[i, 3])
                )
        _inertial_output(q, qg, qc, i)


@njit(cache=True)
def inertial(q, qg, qc, lp, nobs, gyro, accel, dt, mask, tau, ramp, out):
    """inertial_step over (T, n) samples; q after each sample into out (T, n, 4)."""
    for t in range(gyro.shape[0]):
        inertial_step(q, qg, qc, lp, nobs, gyro[t], accel[t], dt[t], mask[t], tau, ramp)
        out[t] = q
