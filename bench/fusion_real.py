"""Fusion on real IMU recordings with optical ground truth: every filter of ours and the field's baselines on the
BROAD trials, with the dataset's error definitions, per trial and mean, in one run.

Data: nine trials of BROAD (D. Laidig, M. Caruso, A. Cereatti, T. Seel, "BROAD - A Benchmark for Robust
Inertial Orientation Estimation", Data 6(7), 2021, doi:10.3390/data6070072; CC BY 4.0), in ../shared/data/broad/
(README there): one real IMU moved by hand, 285.7 Hz, optical truth. Errors (recorder/fusion/truth.py): RMSE of
the inclination error over the movement phase (the 6-D figure), the total error after removing one constant
heading offset, and the heading drift. Every estimator starts from the first samples only:
- ours, host: each fusion config (the default, configs/fusion/*.yaml) through HostFusion as a recording runs it
  (recorder/fusion/truth.py ``host_palm``: register counts, started from the first 1 s of rest);
- ours, glove: the firmware core (firmware/lib/glove_core, host build, glove_core_cli) over the same samples as
  a booting glove: gyro calibration over its first 256 samples, then the filter; pose mode (scored from its
  filter trace and from the pose frames it sends, composed with its reference pose) and compact mode;
- baselines: VQF 6-D online with its defaults (PyPI vqf, by the dataset's authors), imufusion (Ahrs + its gyro
  Bias, gain 0.5), ahrs Madgwick and Mahony with their defaults, the gyro bias of the first 1 s removed and
  started from the first accelerometer sample (as ours).
Robustness: the default host fusion on every trial with dropped samples, saturated registers and NaN bursts
injected (flagged, never propagated: the output stays finite). Tuning: the default's settings (tau_s, ramp) are
chosen leave-one-trial-out: for each trial, the grid point with the lowest mean inclination RMSE over the other
eight, scored on the one left out; the in-sample figures beside them.
Writes bench/results/fusion_real.json and prints the tables of docs/fusion.md.

    .venv/bin/python bench/fusion_real.py [--trials DIR] [--no-ahrs] [--no-tuning]   (about 12 minutes)
"""

from __future__ import annotations

import argparse
import itertools
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from bench._common import REPO, write_results  # noqa: E402
from recorder import quat  # noqa: E402
from recorder.fusion.config import FusionConfig  # noqa: E402
from recorder.fusion.gravity import attitude_from_gravity  # noqa: E402
from recorder.fusion.truth import G, host_palm, load_trial, orientation_errors, registers, stamped_samples  # noqa: E402
from recorder.protocol.frames import EventCode, EventFrame, PoseCompactFrame, PoseFrame  # noqa: E402
from recorder.protocol.stream import StreamDecoder  # noqa: E402

TRIALS = REPO.parent / "shared" / "data" / "broad"
CONFIGS = REPO / "configs" / "fusion"
BUILD = REPO / "build" / "fusion_real"
REST_S = 1.0
GRID = {"tau_s": [2.0, 2.5, 3.0, 3.5, 4.0, 5.0, 6.0, 8.0], "ramp": [0.0, 1.5, 3.0]}


# ------------------------------------------------------------------------------------------------ ours
def host_configs() -> dict[str, FusionConfig]:
    out = {"host default (inertial)": FusionConfig()}
    for path in sorted(CONFIGS.glob("*.yaml")):
        out[f"host {path.stem}.yaml"] = FusionConfig.load(path)
    return out


def run_host(config: FusionConfig, tr) -> np.ndarray:
    q, _ = host_palm(config, registers(tr.gyro, tr.accel / G), tr.t_us, rest_s=REST_S)
    return q


def build_cli() -> Path:
    for cmd in (
        ["cmake", "-S", str(REPO / "firmware"), "-B", str(BUILD), "-DGLOVE_CHECK_ARDUINO_LAYER=OFF"],
        ["cmake", "--build", str(BUILD), "-j", "2", "--target", "glove_core_cli"],
    ):
        done = subprocess.run(cmd, capture_output=True, text=True)
        if done.returncode:
            sys.exit(f"{' '.join(cmd)} failed:\n{done.stdout[-2000:]}{done.stderr[-2000:]}")
    return BUILD / "glove_core_cli"


def run_glove(cli: Path, tr, mode: str) -> dict:
    """The glove's core over the trial (all 12 IMUs read it): its filter trace of IMU 0 (T, 4) and the palm of
    every pose or compact frame in the world (the frame's palm, relative to the reference pose, composed with
    that reference: the filter's attitude at the glove's last POSE_RESET) at the samples the frames were sent."""
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        (tmp / "samples.bin").write_bytes(stamped_samples(tr.gyro, tr.accel / G, tr.t_us))
        cmd = [str(cli), "run", "--stamped", "--mode", mode, "--sense-rate", "286", "--output-rate", "286"]
        cmd += ["--trace", str(tmp / "trace.bin"), "--out", str(tmp / "out.bin"), str(tmp / "samples.bin")]
        subprocess.run(cmd, check=True, capture_output=True)
        trace = np.fromfile(tmp / "trace.bin", "<f8").reshape(len(tr.gyro), 12, 4)[:, 0]
        frames = StreamDecoder("binary").feed((tmp / "out.bin").read_bytes())
    index = {int(t): k for k, t in enumerate(tr.t_us)}
    resets = [index[f.t_us] for f in frames if isinstance(f, EventFrame) and f.code == EventCode.POSE_RESET]
    ref = trace[resets[-1]]
    poses = [f for f in frames if isinstance(f, PoseFrame | PoseCompactFrame) and index[f.t_us] >= resets[-1]]
    at = np.array([index[f.t_us] for f in poses])
    palm = np.array([f.quats[0] if isinstance(f, PoseFrame) else f.palm_quat for f in poses], float)
    sent = np.full((len(tr.gyro), 4), np.nan)
    sent[at] = quat.mul(ref, palm)
    return {"trace": trace, "frames": sent, "n_frames": len(poses)}


# ------------------------------------------------------------------------------------------------ baselines
def start(tr):
    """What every baseline starts from: the gyro bias (mean of the first REST_S seconds) and the attitude from
    the first accelerometer sample (eq. 3.5-3.6)."""
    n = int(REST_S * tr.rate)
    return tr.gyro[:n].mean(axis=0), attitude_from_gravity(tr.accel[0])


def run_vqf(tr) -> np.ndarray:
    from vqf import VQF

    out = VQF(1.0 / tr.rate).updateBatch(np.ascontiguousarray(tr.gyro), np.ascontiguousarray(tr.accel))
    return out["quat6D"]


def run_imufusion(tr) -> np.ndarray:
    import imufusion

    ahrs, bias = imufusion.Ahrs(), imufusion.Bias()
    s = imufusion.AhrsSettings()
    s.convention, s.gain, s.gyroscope_range, s.sample_rate = imufusion.CONVENTION_NWU, 0.5, 2000.0, float(tr.rate)
    s.acceleration_rejection, s.rejection_timeout = 10.0, int(5 * tr.rate)
    ahrs.set_settings(s)
    bs = imufusion.BiasSettings()
    bs.sample_rate = float(tr.rate)
    bias.set_settings(bs)
    gd, ag = np.degrees(tr.gyro), tr.accel / G
    out = np.empty((len(gd), 4))
    for k in range(len(gd)):
        ahrs.update_no_magnetometer(bias.update(gd[k]), ag[k])
        out[k] = ahrs.get_quaternion()
    return out


def run_ahrs(tr, name: str) -> np.ndarray:
    from ahrs.filters import Madgwick, Mahony

    b, q = start(tr)
    f = Madgwick(frequency=tr.rate) if name == "madgwick" else Mahony(frequency=tr.rate)
    g = tr.gyro - b
    out = np.empty((len(g), 4))
    for k in range(len(g)):
        q = f.updateIMU(q, g[k], tr.accel[k])
        out[k] = q
    return out


# ------------------------------------------------------------------------------------------------ robustness
def faults(tr, seed: int = 0):
    """The trial's registers with faults in the movement phase: 20 bursts of 10 dropped samples, 10 bursts of
    5 samples with the gyro's x register saturated (full scale), 10 bursts of 5 samples of NaN (floats, as a
    replayed log may hold). Returns (raw (T, 7) float, ok (T,) bool, counts)."""
    rng = np.random.default_rng(seed)
    raw = registers(tr.gyro, tr.accel / G).astype(float)
    ok = np.ones(len(raw), bool)
    moving = np.flatnonzero(tr.movement)
    starts = rng.choice(moving[:-20], 40, replace=False)
    for k in starts[:20]:
        ok[k : k + 10] = False
    for k in starts[20:30]:
        raw[k : k + 5, 3] = 32767.0
    for k in starts[30:]:
        raw[k : k + 5, :6] = np.nan
    return raw, ok, {"dropped": 200, "saturated": 50, "nan": 50}


# ------------------------------------------------------------------------------------------------ tuning
def tune(trials, seeds: dict) -> dict:
    """Leave-one-trial-out over GRID with the host default pipeline (inclination RMSE)."""
    points = list(itertools.product(*GRID.values()))
    table = np.empty((len(points), len(trials)))
    for p, point in enumerate(points):
        config = FusionConfig(filter_settings=dict(zip(GRID, point)))
        table[p] = [score(run_host(config, tr), tr)["inclination_rmse_deg"] for tr in trials]
        print(f"  grid {dict(zip(GRID, point))}: mean {table[p].mean():.3f}", flush=True)
    folds = []
    for i, tr in enumerate(trials):
        others = np.delete(table, i, axis=1).mean(axis=1)
        best = int(np.argmin(others))
        folds.append(
            {
                "left_out": tr.name,
                "chosen": dict(zip(GRID, points[best])),
                "tuned_on_mean_deg": float(others[best]),
                "left_out_deg": float(table[best, i]),
            }
        )
    everything = int(np.argmin(table.mean(axis=1)))
    left = np.array([f["left_out_deg"] for f in folds])
    default = FusionConfig().filter_settings or {}
    return {
        "rule": "for each trial, the grid point with the lowest mean inclination RMSE over the other eight trials; "
        "scored on the trial left out",
        "grid": GRID,
        "folds": folds,
        "left_out_mean_deg": float(left.mean()),
        "left_out_worst_deg": float(left.max()),
        "best_on_all_nine": dict(zip(GRID, points[everything])),
        "best_on_all_nine_mean_deg": float(table[everything].mean()),
        "default_settings": default,
        "table_deg": {str(dict(zip(GRID, point))): table[p].round(4).tolist() for p, point in enumerate(points)},
    }


# ------------------------------------------------------------------------------------------------ main
def score(q, tr) -> dict:
    return orientation_errors(q, tr.truth, tr.movement, tr.rate)


def summary(per_trial: dict, names: list[str], fast: list[str]) -> dict:
    incl = np.array([per_trial[n]["inclination_rmse_deg"] for n in names])
    return {
        "inclination_mean_deg": float(incl.mean()),
        "inclination_worst_deg": float(incl.max()),
        "worst_over_mean": float(incl.max() / incl.mean()),
        "inclination_fast_mean_deg": float(np.mean([per_trial[n]["inclination_rmse_deg"] for n in fast])),
        "total_mean_deg": float(np.mean([per_trial[n]["total_rmse_deg"] for n in names])),
        "heading_drift_mean_abs_deg_per_min": float(
            np.mean([abs(per_trial[n]["heading_drift_deg_per_min"]) for n in names])
        ),
    }


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--trials", type=Path, default=TRIALS, help="folder of BROAD .hdf5 trials")
    p.add_argument("--no-ahrs", action="store_true", help="skip the ahrs baselines (pure Python: 5 minutes)")
    p.add_argument("--no-tuning", action="store_true", help="skip the leave-one-trial-out grid (2 minutes)")
    args = p.parse_args(argv)
    warnings.filterwarnings("ignore")
    paths = sorted(args.trials.glob("*.hdf5"))
    if not paths:
        sys.exit(f"no BROAD trials (*.hdf5) in {args.trials}")
    trials = [load_trial(path) for path in paths]
    names = [tr.name for tr in trials]
    fast = [n for n in names if "fast" in n]
    cli = build_cli()

    estimators: dict = {name: (lambda tr, c=c: run_host(c, tr)) for name, c in host_configs().items()}
    glove_runs: dict = {}

    def glove(tr, mode, what):
        key = (tr.name, mode)
        if key not in glove_runs:
            glove_runs[key] = run_glove(cli, tr, mode)
        return glove_runs[key][what]

    estimators["glove core: filter (trace)"] = lambda tr: glove(tr, "pose", "trace")
    estimators["glove core: pose frames"] = lambda tr: glove(tr, "pose", "frames")
    estimators["glove core: compact frames"] = lambda tr: glove(tr, "compact", "frames")
    estimators["VQF 6-D (vqf, defaults)"] = run_vqf
    estimators["imufusion (Ahrs + Bias)"] = run_imufusion
    if not args.no_ahrs:
        estimators["ahrs Madgwick (+ start bias)"] = lambda tr: run_ahrs(tr, "madgwick")
        estimators["ahrs Mahony (+ start bias)"] = lambda tr: run_ahrs(tr, "mahony")

    results = {"dataset": "BROAD (Laidig et al., Data 6(7), 2021, doi:10.3390/data6070072, CC BY 4.0)",
               "trials": names, "fast_trials": fast, "estimators": {}}  # fmt: skip
    for name, run in estimators.items():
        t0 = time.perf_counter()
        per = {tr.name: score(run(tr), tr) for tr in trials}
        entry = {"per_trial": per, **summary(per, names, fast), "seconds": round(time.perf_counter() - t0, 1)}
        results["estimators"][name] = entry
        print(
            f"{name:32s} incl mean {entry['inclination_mean_deg']:.3f} worst {entry['inclination_worst_deg']:.3f} "
            f"fast {entry['inclination_fast_mean_deg']:.3f} | "
            + " ".join(f"{per[n]['inclination_rmse_deg']:.2f}" for n in names),
            flush=True,
        )
    vqf = results["estimators"]["VQF 6-D (vqf, defaults)"]
    ours = results["estimators"]["host default (inertial)"]
    core = results["estimators"]["glove core: pose frames"]
    results["goals"] = {
        "host_mean_at_most_vqf": ours["inclination_mean_deg"] <= vqf["inclination_mean_deg"],
        "host_worst_at_most_vqf": ours["inclination_worst_deg"] <= vqf["inclination_worst_deg"],
        "glove_within_1_5_vqf_mean": core["inclination_mean_deg"] <= 1.5 * vqf["inclination_mean_deg"],
        "host_no_trial_above_3x_mean": ours["worst_over_mean"] <= 3.0,
        "glove_no_trial_above_3x_mean": core["worst_over_mean"] <= 3.0,
    }
    print("goals:", results["goals"])

    rob = {}
    for tr in trials:
        raw, ok, injected = faults(tr)
        q, flags = host_palm(FusionConfig(), raw, tr.t_us, ok, rest_s=REST_S)
        rob[tr.name] = {
            **score(q, tr),
            "clean_inclination_rmse_deg": ours["per_trial"][tr.name]["inclination_rmse_deg"],
            "injected_samples": injected,
            "flagged_samples": int(np.count_nonzero(flags)),
            "output_finite": bool(np.isfinite(q).all()),
        }
        r = rob[tr.name]
        print(f"faults {tr.name:45s} {r['inclination_rmse_deg']:.3f} deg (clean "
              f"{r['clean_inclination_rmse_deg']:.3f}), flagged {r['flagged_samples']}")  # fmt: skip
    results["robustness"] = rob
    if not args.no_tuning:
        results["tuning"] = tune(trials, {})
        t = results["tuning"]
        print(f"leave-one-trial-out: left-out mean {t['left_out_mean_deg']:.3f} worst {t['left_out_worst_deg']:.3f}; "
              f"best on all nine {t['best_on_all_nine']} {t['best_on_all_nine_mean_deg']:.3f}")  # fmt: skip
    write_results("fusion_real", results)
    print_tables(results)
    return 0


def print_tables(results: dict) -> None:
    names = results["trials"]
    print("\n| estimator | mean ° | worst ° | fast trials ° | total, heading offset removed ° | |heading drift| °/min |"
          " " + " | ".join(n[:2] for n in names) + " |")  # fmt: skip
    print("|---" * (6 + len(names)) + "|")
    for name, e in results["estimators"].items():
        cells = " | ".join(f"{e['per_trial'][n]['inclination_rmse_deg']:.2f}" for n in names)
        print(
            f"| {name} | {e['inclination_mean_deg']:.3f} | {e['inclination_worst_deg']:.2f} | "
            f"{e['inclination_fast_mean_deg']:.2f} | {e['total_mean_deg']:.2f} | "
            f"{e['heading_drift_mean_abs_deg_per_min']:.2f} | {cells} |"
        )
    if "tuning" in results:
        print("\n| left out | chosen (tau_s, ramp) | tuned-on mean ° | left-out ° |\n|---|---|---|---|")
        for f in results["tuning"]["folds"]:
            c = f["chosen"]
            print(f"| {f['left_out']} | {c['tau_s']}, {c['ramp']} | {f['tuned_on_mean_deg']:.3f} | "
                  f"{f['left_out_deg']:.3f} |")  # fmt: skip


if __name__ == "__main__":
    raise SystemExit(main())
