"""The host pipeline, steps 3-7 of recorder/fusion/host.py's docstring, per frame: ``frame_in`` (step 3) before the
filter's step kernel (step 4) and ``frame_out`` (steps 5-7) after it. The loop over a block of frames that calls
them, with the filter's step between, is generated per filter (recorder/fusion/dispatch.py): the one
implementation HostFusion runs, for one frame live and for a recording."""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from recorder.fusion import kernels as K
from recorder.fusion.kernels import _mul, _normalize, _rotate
from recorder.hand import joints
from recorder.hand.kinematics import DIP, DIP_PER_PIP, LIMITS, PIP, REST
from recorder.hand.skeleton import JOINT_MAP, N_SEGMENTS, PARENTS


def hand_tables():
    """Integer tables of the hand model for the kernels."""
    kind = np.zeros(N_SEGMENTS, np.int64)  # 0: no joint angle (palm), 1: 2-DoF swing, 2: hinge
    flex = np.full(N_SEGMENTS, -1, np.int64)
    abd = np.full(N_SEGMENTS, -1, np.int64)
    for s, f, a in joints.SWING:
        kind[s], flex[s], abd[s] = 1, f, a
    for s, f, _ in joints.HINGE:
        kind[s], flex[s] = 2, f
    parent_imu = np.array([JOINT_MAP.index(PARENTS[s]) if PARENTS[s] in JOINT_MAP else -1 for s in JOINT_MAP])
    return dict(
        imu_seg=np.array(JOINT_MAP, np.int64),
        parents=np.array([max(p, 0) for p in PARENTS], np.int64),
        parent_imu=parent_imu.astype(np.int64),
        kind=kind,
        flex=flex,
        abd=abd,
        rest=REST.copy(),
        limits=LIMITS.copy(),
        pip=np.array(PIP, np.int64),
        dip=np.array(DIP, np.int64),
    )


@njit(cache=True)
def _conj_mul(aw, ax, ay, az, bw, bx, by, bz):
    return _mul(aw, -ax, -ay, -az, bw, bx, by, bz)


@njit(cache=True)
def _swing(w, x, y, z, steps):
    """joints.swing_angles for one quaternion: (flexion, abduction)."""
    r00 = 1 - 2 * (y * y + z * z)
    r01 = 2 * (x * y - w * z)
    r02 = 2 * (x * z + w * y)
    r10 = 2 * (x * y + w * z)
    r11 = 1 - 2 * (x * x + z * z)
    r12 = 2 * (y * z - w * x)
    r20 = 2 * (x * z - w * y)
    r22 = 1 - 2 * (x * x + y * y)
    a = math.atan2(-r01, r11)
    for _ in range(steps):
        ca, sa = math.cos(a), math.sin(a)
        p = ca * r00 + sa * r10 + r22
        s = ca * r02 + sa * r12 - r20
        dp = -sa * r00 + ca * r10
        ds = -sa * r02 + ca * r12
        n = math.sqrt(p * p + s * s) + 1e-300
        g1 = (p * dp + s * ds) / n - sa * r11 - ca * r01
        g2 = (
            (dp * dp - p * (p - r22) + ds * ds - s * (s + r20)) / n
            - (p * dp + s * ds) ** 2 / n**3
            - ca * r11
            + sa * r01
        )
        if g2 < -1e-9:
            a = a - g1 / g2
        else:
            a = a + 0.5 * g1
    ca, sa = math.cos(a), math.sin(a)
    f = math.atan2(ca * r02 + sa * r12 - r20, ca * r00 + sa * r10 + r22)
    return f, (a + math.pi) % (2.0 * math.pi) - math.pi


@njit(cache=True)
def _from_angles(angles, kind, flex, abd, rest, out):
    """Parent-relative quats (16, 4) of the model at ``angles`` (kinematics: REST Rz(abd) Ry(flex))."""
    for s in range(out.shape[0]):
        f = angles[flex[s]] if flex[s] >= 0 else 0.0
        a = angles[abd[s]] if abd[s] >= 0 else 0.0
        sw = _mul(math.cos(0.5 * a), 0.0, 0.0, math.sin(0.5 * a), math.cos(0.5 * f), 0.0, math.sin(0.5 * f), 0.0)
        out[s, 0], out[s, 1], out[s, 2], out[s, 3] = _mul(rest[s, 0], rest[s, 1], rest[s, 2], rest[s, 3], *sw)


@njit(cache=True)
def _relative(g, parents, out):
    """kinematics.relative_quats."""
    out[0] = g[0]
    for s in range(1, g.shape[0]):
        p = parents[s]
        out[s, 0], out[s, 1], out[s, 2], out[s, 3] = _conj_mul(
            g[p, 0], g[p, 1], g[p, 2], g[p, 3], g[s, 0], g[s, 1], g[s, 2], g[s, 3]
        )


@njit(cache=True)
def hand_step(
    seg,
    fuse,
    tab_imu_seg,
    parents,
    parent_imu,
    share,
    min_vis,
    kind,
    flex,
    abd,
    rest,
    limits,
    pip,
    dip,
    use_limits,
    g16,
    rel,
    crel,
    free,
    angles,
    quats,
    psi,
    bvec,
    constraint,
):
    """Step 6 and the heading corrections of step 7 (host.py) for one frame: seg (12, 4) orientations of the
    IMU segments in the world; writes angles (20,), quats (16, 4), psi (12,), bvec (12, 3) and constraint (12,)."""
    n_seg = g16.shape[0]
    for s in range(n_seg):
        g16[s, 0], g16[s, 1], g16[s, 2], g16[s, 3] = 1.0, 0.0, 0.0, 0.0
    for i in range(seg.shape[0]):
        g16[tab_imu_seg[i]] = seg[i]
    for s in range(1, n_seg):  # segments without an IMU follow their parent (parents come first)
        has = False
        for i in range(seg.shape[0]):
            if tab_imu_seg[i] == s:
                has = True
        if not has:
            g16[s] = g16[parents[s]]
    _relative(g16, parents, rel)
    for j in range(free.shape[0]):
        free[j] = 0.0
    for s in range(1, n_seg):
        if kind[s] == 0:
            continue
        w, x, y, z = _conj_mul(
            rest[s, 0], rest[s, 1], rest[s, 2], rest[s, 3], rel[s, 0], rel[s, 1], rel[s, 2], rel[s, 3]
        )
        if kind[s] == 1:
            f, a = _swing(w, x, y, z, 4)
            free[flex[s]] = f
            free[abd[s]] = a
        else:
            h = 2.0 * math.atan2(y, w)
            free[flex[s]] = (h + math.pi) % (2.0 * math.pi) - math.pi
    _from_angles(free, kind, flex, abd, rest, crel)
    crel[0] = g16[0]
    for i in range(seg.shape[0]):
        psi[i] = 0.0
        bvec[i, 0] = bvec[i, 1] = bvec[i, 2] = 0.0
    for i in range(seg.shape[0]):
        s = tab_imu_seg[i]
        pi = parent_imu[i]
        if pi >= 0 and fuse[i] and fuse[pi]:
            p = parents[s]
            cw, cx, cy, cz = _mul(
                g16[p, 0], g16[p, 1], g16[p, 2], g16[p, 3], crel[s, 0], crel[s, 1], crel[s, 2], crel[s, 3]
            )
            if kind[s] == 2:
                ax, ay, az = _rotate(cw, cx, cy, cz, 0.0, 1.0, 0.0)
                sx, sy, sz = -az * ax, -az * ay, 1.0 - az * az
            else:
                ax, ay, az = _rotate(cw, cx, cy, cz, 1.0, 0.0, 0.0)
                sx, sy, sz = az * ax, az * ay, az * az
            if sz < min_vis:
                continue
            ew, ex, ey, ez = _mul(cw, cx, cy, cz, seg[i, 0], -seg[i, 1], -seg[i, 2], -seg[i, 3])
            h = 2.0 * math.atan2(ez, ew)
            h = (h + math.pi) % (2.0 * math.pi) - math.pi
            bvec[i, 0] += (1.0 - share) * h * sx
            bvec[i, 1] += (1.0 - share) * h * sy
            bvec[i, 2] += (1.0 - share) * h * sz
            bvec[pi, 0] -= share * h * sx
            bvec[pi, 1] -= share * h * sy
            bvec[pi, 2] -= share * h * sz
            psi[i] += (1.0 - share) * h
            psi[pi] -= share * h
    for i in range(seg.shape[0]):
        s = tab_imu_seg[i]
        if s == 0:
            constraint[i] = 0.0
        else:
            dw, dx, dy, dz = _conj_mul(
                rel[s, 0], rel[s, 1], rel[s, 2], rel[s, 3], crel[s, 0], crel[s, 1], crel[s, 2], crel[s, 3]
            )
            constraint[i] = 2.0 * math.atan2(math.sqrt(dx * dx + dy * dy + dz * dz), abs(dw))
    for j in range(free.shape[0]):
        v = free[j]
        if use_limits:
            v = min(max(v, limits[j, 0]), limits[j, 1])
        angles[j] = v
    for k in range(pip.shape[0]):
        angles[dip[k]] = DIP_PER_PIP * max(angles[pip[k]], 0.0)
    _from_angles(angles, kind, flex, abd, rest, quats)
    quats[0] = g16[0]


@njit(cache=True)
def scratch(n, n_joints):
    """The per-frame work arrays of ``frame_in`` and ``frame_out``: dt (n,), the bias-corrected gyro (n, 3), the
    accelerometer trust, the bias feedback gains, the segments and the hand model's buffers."""
    return (
        np.empty(n),  # 0 dt
        np.empty((n, 3)),  # 1 gyro, tracked bias removed (what the filter's step takes)
        np.empty(n),  # 2 trust
        np.empty(n),  # 3 heading-bias gains
        np.empty((n, 4)),  # 4 IMU segments in the world
        np.empty((N_SEGMENTS, 4)),  # 5 all 16 segments
        np.empty((N_SEGMENTS, 4)),  # 6 parent-relative
        np.empty((N_SEGMENTS, 4)),  # 7 constrained parent-relative
        np.empty(n_joints),  # 8 free joint angles
        np.empty(n),  # 9 heading errors
        np.empty((n, 3)),  # 10 bias feedback vectors
    )


@njit(cache=True)
def frame_in(t, host, inputs, outputs, work):
    """Step 3 of host.py for frame t: dt per IMU from the device clock (at most max_dt; after missed frames the gap
    is integrated at the mean of the rates at its two ends), the accelerometer's error and trust, the gyro with the
    tracked bias removed. host: (b, still_for, bp, use_gravity, track_bias, C, heading, last_t, last_g, missed,
    minv, heading_rate, heading_bias_rate, max_dt, share, min_vis); inputs: (accel, gyro, t_us, fuse)."""
    b, last_t, last_g, missed, max_dt = host[0], host[7], host[8], host[9], host[13]
    accel, gyro, t_us, fuse = inputs
    o_aerr = outputs[2]
    dt, gc, trust = work[0], work[1], work[2]
    for i in range(gyro.shape[1]):
        d = ((t_us[t] - last_t[i]) & 0xFFFFFFFF) * 1e-6
        dt[i] = min(max(d, 0.0), max_dt)
        if fuse[t, i]:
            last_t[i] = t_us[t]
        an = math.sqrt(accel[t, i, 0] ** 2 + accel[t, i, 1] ** 2 + accel[t, i, 2] ** 2)
        o_aerr[t, i] = abs(an - 1.0)
        trust[i] = K._gain_factor(an, 0.1, 0.2)
        for c in range(3):
            gc[i, c] = gyro[t, i, c] - b[i, c]
        if fuse[t, i]:
            for c in range(3):
                g = gc[i, c]
                if missed[i]:
                    gc[i, c] = 0.5 * (g + last_g[i, c])
                last_g[i, c] = g
            missed[i] = False
        else:
            missed[i] = True


@njit(cache=True)
def frame_out(t, q, fbias, host, tables, inputs, outputs, work):
    """Steps 5-7 of host.py for frame t, after the filter's step: bias tracking, the hand model, the joint
    constraints' heading feedback, and the outputs (quats, angles, trust, bias, constraint, heading).
    tables: (imu_seg, parents, parent_imu, kind, flex, abd, rest, limits, pip, dip, use_limits), hand_tables()."""
    b, still_for, bp, use_gravity, track_bias, C, heading = host[:7]
    minv, heading_rate, heading_bias_rate, share, min_vis = host[10], host[11], host[12], host[14], host[15]
    accel, gyro, t_us, fuse = inputs
    o_quats, o_angles, o_aerr, o_trust, o_bias, o_constraint, o_heading = outputs
    dt, trust, kb, seg, g16, relq, crel, free, psi, bvec = (
        work[0], work[2], work[3], work[4], work[5], work[6], work[7], work[8], work[9], work[10]
    )  # fmt: skip
    n = gyro.shape[1]
    if track_bias:
        K.bias_step(b, still_for, gyro[t], accel[t], q, trust, dt, fuse[t], bp, use_gravity)
    for i in range(n):
        w, x, y, z = _mul(C[i, 0], C[i, 1], C[i, 2], C[i, 3], q[i, 0], q[i, 1], q[i, 2], q[i, 3])
        seg[i, 0], seg[i, 1], seg[i, 2], seg[i, 3] = _mul(w, x, y, z, minv[i, 0], minv[i, 1], minv[i, 2], minv[i, 3])
    hand_step(seg, fuse[t], tables[0], tables[1], tables[2], share, min_vis, tables[3], tables[4], tables[5],
              tables[6], tables[7], tables[8], tables[9], tables[10], g16, relq, crel, free, o_angles[t], o_quats[t],
              psi, bvec, o_constraint[t])  # fmt: skip
    if heading_rate > 0.0:
        for i in range(n):
            step = heading_rate * dt[i] * psi[i]
            C[i, 0], C[i, 1], C[i, 2], C[i, 3] = _normalize(
                *_mul(math.cos(0.5 * step), 0.0, 0.0, math.sin(0.5 * step), C[i, 0], C[i, 1], C[i, 2], C[i, 3])
            )
            heading[i] += step
        if track_bias and heading_bias_rate > 0.0:
            for i in range(n):
                kb[i] = heading_bias_rate * dt[i]
            K.bias_heading(b, q, bvec, kb, fuse[t])
    for i in range(n):
        o_trust[t, i] = trust[i]
        o_bias[t, i] = math.sqrt(
            (b[i, 0] + fbias[i, 0]) ** 2 + (b[i, 1] + fbias[i, 1]) ** 2 + (b[i, 2] + fbias[i, 2]) ** 2
        )
        o_heading[t, i] = heading[i]
