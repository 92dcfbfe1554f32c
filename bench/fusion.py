"""Fusion accuracy and cost on emulated glove data with ground truth.

For each rate (200 Hz, 1 kHz) and motion ("gestures", "random"; at 200 Hz also "gestures_fast" and "random_fast",
the same motions played twice as fast: finger rates up to 1800 deg/s, hand accelerations up to 13 g, just inside
the MPU9250's 2000 deg/s and 16 g): a SyntheticGlove with datasheet noise and
temperature-drifting bias (recorder/emulator defaults) whose wearer first runs the calibration procedure
(recorder/emulator/procedure.py, 17 s), then 60 s of motion, which is what is scored. Every estimator gets the same
calibration (gyro bias, accelerometer offsets, sensor-to-segment alignment, reference pose) and the same hand
model (joint dimensionality, limits, eq. 3.3):
- ours: HostFusion with each filter (complementary = the thesis' filter, mahony = Santaera Alg. 1, relative =
  Alg. 2, madgwick), full pipeline (online bias tracking, joint-constraint heading feedback);
- ours, filter only: the same filters without bias tracking and constraint feedback;
- ours, no constraints: the default filter (inertial) with its bias tracking but without the joint constraints
  (no constraint feedback, no joint limits): what Kortier's constraints add to a single-IMU filter;
- baselines: ahrs Madgwick, Mahony, AQUA (gain set per update to the thesis' 0.005 with the eq. 3.19 ramp,
  since adaptive=True would overwrite it with 0.1) and imufusion (Ahrs + its gyro Bias), one object per IMU.
Scores: per-joint RMS angle error, fingertip position RMS error (palm frame), relative heading drift (slope of
the heading error of each segment relative to the palm, deg/min), and cost per 12-IMU step (median of runs).
Writes bench/results/fusion.json and bench/results/fusion_error.png.

    .venv/bin/python bench/fusion.py [--seconds 60] [--rates 200 1000] [--fast-rates 200] [--quick] [--cost-only]
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from bench._common import RESULTS, write_results  # noqa: E402
from recorder import quat  # noqa: E402
from recorder.emulator import procedure as emulated  # noqa: E402
from recorder.fusion.block import filter_block  # noqa: E402
from recorder.fusion.gravity import gain_factor  # noqa: E402
from recorder.fusion.host import FusionConfig, HostFusion  # noqa: E402
from recorder.fusion.registry import filter_names, make_filter  # noqa: E402
from recorder.hand import joints  # noqa: E402
from recorder.hand.kinematics import JOINTS, global_from_relative, relative_quats  # noqa: E402
from recorder.hand.motion import MotionBlock, SampledMotion  # noqa: E402
from recorder.hand.skeleton import FINGERS, JOINT_MAP, N_SEGMENTS, PARENTS  # noqa: E402
from recorder.protocol.frames import RawFrame  # noqa: E402

G_AHRS = 9.809196  # ahrs' gravity, so its |a| - g matches ours in g
IMU_SEG = list(JOINT_MAP)


# ------------------------------------------------------------------------------------------------ data
FAST = 2.0  # "<kind>_fast": the motion played this much faster


class Faster(SampledMotion):
    """A motion played ``speed`` times as fast (angles and palm pose at speed * t)."""

    def __init__(self, base: SampledMotion, speed: float):
        super().__init__(base.rate_hz)
        self.base, self.speed = base, float(speed)

    def at(self, t) -> MotionBlock:
        t = np.asarray(t, float)
        m = self.base.at(t * self.speed)
        return MotionBlock(t, m.angles, m.palm_quat, m.palm_pos)


def make_data(kind: str, rate: int, seconds: float, seed: int) -> dict:
    base = kind.removesuffix("_fast")
    glove = emulated.procedure_glove(base, rate, seed)
    if base != kind:
        glove.motion.motion = Faster(glove.motion.motion, FAST)
    b = glove.next_block(int(round((emulated.START + seconds) * rate)))
    t_us = np.round(np.arange(len(b.t)) * 1e6 / rate).astype(np.int64)
    return {
        "block": b,
        "raw": b.raw,
        "t_us": t_us,
        "rate": rate,
        "start": int(round(emulated.START * rate)),
        "rest": emulated.phase("rest", rate),
        "kind": kind,
    }


def calibrated(d: dict, config: FusionConfig) -> HostFusion:
    """A HostFusion calibrated on the procedure and started at the end of its rest step."""
    raw, t, rate = d["raw"], d["t_us"], d["rate"]
    hf = HostFusion(config)
    rec = {p: (raw[emulated.phase(p, rate)], t[emulated.phase(p, rate)]) for p in emulated.PHASES}
    hf.calibrate(rec["still"], rec["flex"], rec["tilt"])
    hf.start(rec["rest"])
    return hf


# ------------------------------------------------------------------------------------------------ scoring
def palm_relative(quats16) -> np.ndarray:
    g = global_from_relative(quats16)
    return quat.mul(quat.conj(g[..., :1, :]), g)


def score(d: dict, angles, quats16) -> dict:
    """Errors over the scored part (from the motion's start); angles (T, 20), quats16 (T, 16, 4) estimates."""
    b, k0, rate = d["block"], d["start"], d["rate"]
    err = np.degrees(angles[k0:] - b.angles[k0:])
    tips = joints.fingertips(angles[k0:])
    tips_true = joints.fingertips(b.angles[k0:])
    tip_err = np.linalg.norm(tips - tips_true, axis=-1) * 1000.0
    e = quat.mul(palm_relative(quats16[k0:]), quat.conj(palm_relative(b.truth_rel[k0:])))
    heading = np.degrees(np.unwrap(2.0 * np.arctan2(e[..., 3], e[..., 0]), axis=0))[:, IMU_SEG[1:]]
    minutes = np.arange(len(heading)) / rate / 60.0
    slope = np.polyfit(minutes, heading, 1)[0]  # deg/min per IMU segment
    per_joint = np.sqrt(np.mean(err**2, axis=0))
    win = rate  # 1-s windows for the plot
    n = len(err) // win
    return {
        "joint_rms_deg": float(np.sqrt(np.mean(err**2))),
        "joint_rms_max_deg": float(per_joint.max()),
        "worst_joint": JOINTS[int(per_joint.argmax())],
        "per_joint_rms_deg": {j: round(float(v), 3) for j, v in zip(JOINTS, per_joint)},
        "fingertip_rms_mm": float(np.sqrt(np.mean(tip_err**2))),
        "per_fingertip_rms_mm": {f: round(float(v), 3) for f, v in zip(FINGERS, np.sqrt(np.mean(tip_err**2, 0)))},
        "heading_drift_max_deg_per_min": float(np.max(np.abs(slope))),
        "heading_drift_mean_deg_per_min": float(np.mean(np.abs(slope))),
        "error_over_time_deg": np.sqrt(np.mean(err[: n * win].reshape(n, win, -1) ** 2, axis=(1, 2))).round(3).tolist(),
    }


def hand_model(hf: HostFusion, q_imu) -> tuple[np.ndarray, np.ndarray]:
    """Baselines: the same reference, mounts and hand model (no feedback), for IMU orientations (T, 12, 4)."""
    seg = quat.mul(quat.mul(hf.C[None], q_imu), quat.conj(hf.calibration.mounts)[None])
    g16 = np.tile(quat.IDENTITY, q_imu.shape[:1] + (N_SEGMENTS, 1))
    g16[:, IMU_SEG] = seg
    for s in range(N_SEGMENTS):
        if s not in JOINT_MAP:
            g16[:, s] = g16[:, PARENTS[s]]
    angles = joints.joint_angles(relative_quats(g16))
    quats = joints.constrained_relative(angles)
    quats[:, 0] = g16[:, 0]
    return angles, quats


# ------------------------------------------------------------------------------------------------ ours
def run_ours(d: dict, name: str, full: bool, runs: int, constraints: bool = True) -> dict:
    if not constraints:  # bias tracking, but no joint-constraint feedback and no joint limits
        config = FusionConfig(filter=name, rate_hz=d["rate"], heading_rate=0.0, limits=False)
    elif full:
        config = FusionConfig(filter=name, rate_hz=d["rate"])
    else:
        config = FusionConfig(filter=name, rate_hz=d["rate"], track_bias=False, heading_rate=0.0)
    k1 = d["rest"].stop
    raw, t = d["raw"][k1:], d["t_us"][k1:]
    costs, out = [], None
    for _ in range(runs):
        hf = calibrated(d, config)
        t0 = time.perf_counter()
        out = hf.process_block(raw, t)
        costs.append((time.perf_counter() - t0) / len(raw) * 1e6)
    angles = np.concatenate((np.zeros((k1, 20)), out.angles))
    quats = np.concatenate((np.tile(quat.IDENTITY, (k1, 16, 1)), out.quats))
    res = score(d, angles, quats)
    res["cost_block_us_per_frame"] = statistics.median(costs)
    res["flagged_frames"] = int(np.count_nonzero(out.flags.any(axis=1)))
    return res


def filter_cost(name: str, rate: int, runs: int, T: int = 20000) -> dict:
    """The block API alone (``filter_block``, the numba kernels), per 12-IMU step, on random motion."""
    glove = emulated.SyntheticGlove("random", rate, 7)
    b = glove.next_block(T)
    a = b.raw[..., 0:3] * (16 / 32768.0)
    g = np.radians(b.raw[..., 3:6] * (2000 / 32768.0))
    times = []
    for _ in range(runs):
        f = make_filter(name)
        f.reset(a[0])
        filter_block(f, g[:2], a[:2], 1.0 / rate)  # compile / warm up
        t0 = time.perf_counter()
        filter_block(f, g, a, 1.0 / rate)
        times.append((time.perf_counter() - t0) / T * 1e6)
    return {"numba_us_per_step": statistics.median(times)}


def live_cost(d: dict, name: str, frames: int = 2000) -> float:
    """HostFusion.process, one RawFrame at a time (what the recorder does live): median µs per frame."""
    hf = calibrated(d, FusionConfig(filter=name, rate_hz=d["rate"]))
    k1 = d["rest"].stop
    fr = [RawFrame(k & 0xFFFF, int(d["t_us"][k1 + k]), d["raw"][k1 + k]) for k in range(frames)]
    times = []
    for f in fr:
        t0 = time.perf_counter()
        hf.process(f)
        times.append(time.perf_counter() - t0)
    return float(np.median(times[100:]) * 1e6)


def measure_cost(rates: list[int], seed: int, runs: int) -> dict:
    """filter_cost and live_cost of every filter at each rate."""
    cost = {}
    for rate in rates:
        d = make_data("gestures", rate, 15.0, seed)
        for name in filter_names():
            c = cost[f"{name}@{rate}Hz"] = filter_cost(name, rate, runs)
            c["live_us_per_frame"] = live_cost(d, name)
            print(f"cost {name}@{rate}Hz {c}", flush=True)
    return cost


def long_run(seed: int, minutes: float = 4.0, rate: int = 200) -> dict:
    """Drift or wander, and is the feedback stable? Every filter on 4 minutes of random motion (the bias keeps
    drifting with temperature): joint and heading RMS error minute by minute, the heading slope over the run."""
    d = make_data("random", rate, minutes * 60.0, seed)
    return {name: _long_run(d, name, minutes, rate) for name in filter_names()}


def _long_run(d: dict, name: str, minutes: float, rate: int) -> dict:
    hf = calibrated(d, FusionConfig(filter=name, rate_hz=rate))
    k1, k0 = d["rest"].stop, d["start"]
    out = hf.process_block(d["raw"][k1:], d["t_us"][k1:])
    quats = np.concatenate((np.tile(quat.IDENTITY, (k1, 16, 1)), out.quats))
    e = quat.mul(palm_relative(quats[k0:]), quat.conj(palm_relative(d["block"].truth_rel[k0:])))
    heading = np.degrees(np.unwrap(2.0 * np.arctan2(e[..., 3], e[..., 0]), axis=0))[:, IMU_SEG[1:]]
    per_min = heading[: int(minutes) * 60 * rate].reshape(int(minutes), 60 * rate, -1)
    slope = np.polyfit(np.arange(len(heading)) / rate / 60.0, heading, 1)[0]
    err = np.degrees(out.angles[k0 - k1 :] - d["block"].angles[k0:])[: int(minutes) * 60 * rate]
    err = err.reshape(int(minutes), 60 * rate, -1)
    return {
        "motion": "random",
        "rate_hz": rate,
        "minutes": minutes,
        "heading_drift_max_deg_per_min": float(np.max(np.abs(slope))),
        "heading_rms_by_minute_deg": np.sqrt(np.mean(per_min**2, axis=(1, 2))).round(3).tolist(),
        "joint_rms_by_minute_deg": np.sqrt(np.mean(err**2, axis=(1, 2))).round(3).tolist(),
        "worst_joint_rms_last_minute_deg": float(np.sqrt(np.mean(err[-1] ** 2, axis=0)).max()),
    }


# ------------------------------------------------------------------------------------------------ baselines
def corrected_inputs(d: dict, hf: HostFusion):
    k1 = d["rest"].stop
    raw = d["raw"]
    a = raw[..., 0:3] * (16 / 32768.0) - hf.calibration.accel_offset
    g = np.radians(raw[..., 3:6] * (2000 / 32768.0)) - hf.calibration.gyro_bias
    return k1, g, a


def run_baseline(d: dict, name: str) -> dict:
    from ahrs.filters import AQUA, Madgwick, Mahony

    hf = calibrated(d, FusionConfig(rate_hz=d["rate"], track_bias=False, heading_rate=0.0))
    k1, g, a = corrected_inputs(d, hf)
    rate = d["rate"]
    dt = 1.0 / rate
    T = len(g)
    q0 = hf.filter.q.copy()  # attitude from gravity at the start (eq. 3.5-3.6): the same start for everyone
    C0 = hf.C.copy()
    out = np.tile(quat.IDENTITY, (T, 12, 1))
    t0 = time.perf_counter()
    if name == "imufusion":
        import imufusion

        filters, offsets = [], []
        for i in range(12):
            f = imufusion.Ahrs()
            s = imufusion.AhrsSettings()
            s.convention, s.gain, s.gyroscope_range = imufusion.CONVENTION_NWU, 0.5, 2000.0
            s.acceleration_rejection, s.rejection_timeout, s.sample_rate = 10.0, 5 * rate, float(rate)
            f.set_settings(s)
            f.set_quaternion(q0[i])
            f.skip_startup() if hasattr(f, "skip_startup") else None
            o = imufusion.Bias()
            bs = imufusion.BiasSettings()
            bs.sample_rate = float(rate)
            o.set_settings(bs)
            filters.append(f)
            offsets.append(o)
        gd = np.degrees(g)
        for k in range(k1, T):
            for i in range(12):
                filters[i].update_no_magnetometer(offsets[i].update(gd[k, i]), a[k, i])
                out[k, i] = filters[i].get_quaternion()
    else:
        if name == "ahrs_madgwick":
            f = Madgwick(frequency=float(rate))
        elif name == "ahrs_madgwick_at_our_gain":
            f = Madgwick(frequency=float(rate), gain=0.01)
        elif name == "ahrs_mahony":
            f = Mahony(frequency=float(rate))
        elif name == "ahrs_mahony_at_our_gains":
            f = Mahony(frequency=float(rate), k_P=0.5, k_I=0.002)
        else:
            f = AQUA(frequency=float(rate), adaptive=False, alpha=0.005)
        aqua = name == "ahrs_aqua"
        q = [quat.conj(q0[i]) if aqua else q0[i].copy() for i in range(12)]
        am = a * G_AHRS
        trust = gain_factor(np.linalg.norm(a, axis=2))
        for k in range(k1, T):
            for i in range(12):
                if aqua:
                    f.alpha = max(0.005 * trust[k, i], 1e-12)  # the gain per update (adaptive=True -> 0.1)
                q[i] = f.updateIMU(q[i], g[k, i], am[k, i], dt=dt)
                out[k, i] = quat.conj(q[i]) if aqua else q[i]
    per_step = (time.perf_counter() - t0) / (T - k1) * 1e6
    hf.C = C0
    angles, quats = hand_model(hf, out)
    angles[:k1] = 0.0
    res = score(d, angles, quats)
    res["cost_us_per_step"] = per_step
    return res


# ------------------------------------------------------------------------------------------------ main
def plot(results: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    cases = list(results["accuracy"])
    fig, axes = plt.subplots(len(cases), 1, figsize=(10, 3.2 * len(cases)), squeeze=False)
    for ax, case in zip(axes[:, 0], cases):
        for name, r in results["accuracy"][case].items():
            style = "-" if name.startswith("ours") else ":"
            ax.plot(r["error_over_time_deg"], style, label=f"{name} ({r['joint_rms_deg']:.2f}°)", lw=1.2)
        ax.set_title(f"{case}: joint-angle RMS error per second")
        ax.set_xlabel("time since the motion started (s)")
        ax.set_ylabel("RMS error (deg)")
        ax.set_yscale("log")
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=7, ncol=3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    print(f"wrote {path}")


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--seconds", type=float, default=60.0)
    p.add_argument("--rates", type=int, nargs="+", default=[200, 1000])
    p.add_argument("--motions", nargs="+", default=["gestures", "random"])
    p.add_argument("--fast-rates", type=int, nargs="*", default=[200], help="rates with the fast motions too")
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--runs", type=int, default=5, help="timing runs (median)")
    p.add_argument("--no-baselines", action="store_true")
    p.add_argument("--quick", action="store_true", help="10 s, 200 Hz, gestures, 1 run")
    p.add_argument("--cost-only", action="store_true", help="measure the cost again, keep the rest of fusion.json "
                   "(for a quiet machine: the accuracy runs do not depend on load, the timings do)")  # fmt: skip
    args = p.parse_args(argv)
    if args.quick:
        args.seconds, args.rates, args.motions, args.runs, args.fast_rates = 10.0, [200], ["gestures"], 1, []
    warnings.filterwarnings("ignore")
    baselines = (
        []
        if args.no_baselines
        else [
            "ahrs_madgwick",
            "ahrs_madgwick_at_our_gain",
            "ahrs_mahony",
            "ahrs_mahony_at_our_gains",
            "ahrs_aqua",
            "imufusion",
        ]
    )
    if args.cost_only:
        results = json.loads((RESULTS / "fusion.json").read_text())
        results.pop("meta", None)
        results["cost"] = measure_cost(args.rates, args.seed, args.runs)
        write_results("fusion", results)
        return 0
    results = {"config": vars(args), "accuracy": {}, "cost": {}}
    default = FusionConfig().filter
    for rate in args.rates:
        motions = args.motions + ([f"{m}_fast" for m in args.motions] if rate in args.fast_rates else [])
        for kind in motions:
            case = f"{kind}@{rate}Hz"
            d = make_data(kind, rate, args.seconds, args.seed)
            acc = results["accuracy"][case] = {}
            for name in filter_names():
                acc[f"ours_{name}"] = run_ours(d, name, True, args.runs)
                acc[f"ours_{name}_filter_only"] = run_ours(d, name, False, 1)
                if name == default:
                    acc[f"ours_{name}_no_constraints"] = run_ours(d, name, True, 1, constraints=False)
                print(
                    f"{case:18s} ours_{name:14s} {acc[f'ours_{name}']['joint_rms_deg']:.2f} deg "
                    f"{acc[f'ours_{name}']['fingertip_rms_mm']:.2f} mm "
                    f"{acc[f'ours_{name}']['heading_drift_max_deg_per_min']:.2f} deg/min",
                    flush=True,
                )
            for name in baselines:
                acc[name] = run_baseline(d, name)
                print(
                    f"{case:18s} {name:19s} {acc[name]['joint_rms_deg']:.2f} deg "
                    f"{acc[name]['fingertip_rms_mm']:.2f} mm "
                    f"{acc[name]['heading_drift_max_deg_per_min']:.2f} deg/min",
                    flush=True,
                )
    results["cost"] = measure_cost(args.rates, args.seed, args.runs)
    if not args.quick:
        results["long_run"] = long_run(args.seed)
        for name, v in results["long_run"].items():
            print(f"long run {name}: joint RMS by minute {v['joint_rms_by_minute_deg']}", flush=True)
    write_results("fusion", results)
    plot(results, RESULTS / "fusion_error.png")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
