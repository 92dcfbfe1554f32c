"""Soak benchmark: an hour of `gloverec record` as a person runs it, to see whether anything drifts.

    .venv/bin/python bench/soak.py [--minutes 60] [--unplug-every-s 300] [--unplugged-s 10]

A separate `gloverec emulate` process is the glove (200 Hz, random motion, on a pseudo-terminal behind a stable
link, as udev gives a USB glove). `gloverec record --realtime --fps 30 --view web:PORT` records HandPose on
glovehand into a fresh dataset, with its session log, for --minutes; headless Chromium keeps the web view's page open
the whole time (as an unprivileged user, as a person's browser runs). Every --unplug-every-s the glove's cable is
pulled (`kill -USR1` on the emulator) and put back --unplugged-s later (`kill -USR2`); every episode ends with the
reset period. At the end the recording is stopped with Ctrl-C (SIGINT), as a person stops it.

Sampled every --sample-s: the resident memory, open files and threads of the recording process and of its children
(the writer process, the view process), and the session log's size. Afterwards, from the dataset read back by
LeRobotDataset: glove sample -> action latency p50 and p99 per 5-minute window (by when each episode started),
frames lost outside the unplugged intervals (glove frames dropped in saved episodes, and frames missing from saved
episodes that did not end early), episodes saved against those recorded (started), and whether each saved episode
loads with its frames.

Goals: RSS growth <= 50 MB (from the first saved episode to the end), latency p99 in the last window within 20 % of the
first, 0 frames lost outside the unplugged intervals, every saved episode loads. Writes bench/results/soak.json and
docs/images/soak.png.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import signal
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import REPO, browser, write_results  # noqa: E402

os.environ.setdefault("MUJOCO_GL", "egl")
os.environ.setdefault("HF_HUB_OFFLINE", "1")

import psutil  # noqa: E402  (lerobot's dependency: the processes' memory, files and threads)

WINDOW_S = 300.0
STARTED = re.compile(r"episode (\d+) started")
SAVED = re.compile(r"episode (\d+) saved: (\d+) frames")
DISCARDED = re.compile(r"episode (\d+) discarded: (.*)")


def _role(child: psutil.Process, main: list[str]) -> str:
    """What a child of the recording process is: its writer (a fork: the same command line), the view (a fresh
    interpreter: multiprocessing's spawn) or another helper (multiprocessing's resource tracker)."""
    cmd = child.cmdline()
    if cmd == main:
        return "writer"
    return "view" if any("spawn_main" in c for c in cmd) else "other"  # the view: multiprocessing's spawn


def _tree(proc: psutil.Process) -> dict:
    """RSS (MB), open files and threads of the recording process, and the RSS of each of its children's roles."""
    with proc.oneshot():
        out = {"rss_mb": round(proc.memory_info().rss / 2**20, 1), "fds": proc.num_fds(), "threads": proc.num_threads()}
        main = proc.cmdline()
    roles: dict[str, float] = {}
    fds = threads = 0
    for child in proc.children(recursive=True):
        try:
            with child.oneshot():
                role = _role(child, main)
                roles[role] = roles.get(role, 0.0) + child.memory_info().rss / 2**20
                fds, threads = fds + child.num_fds(), threads + child.num_threads()
        except psutil.Error:  # ended between the listing and the reading
            continue
    return {**out, "children_rss_mb": round(sum(roles.values()), 1), "children_fds": fds, "children_threads": threads,
            **{f"{role}_rss_mb": round(rss, 1) for role, rss in sorted(roles.items())}}  # fmt: skip


def _log_bytes(root: Path) -> int:
    logs = root / "logs"
    return sum(f.stat().st_size for f in logs.glob("*.mcap")) if logs.exists() else 0


def soak(minutes: float, unplug_every_s: float, unplugged_s: float, sample_s: float, episode_s: float) -> dict:
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        link, root = tmp / "glove", tmp / "ds"
        emu = subprocess.Popen([sys.executable, "-m", "recorder.cli", "emulate", "--rate", "200", "--link", str(link),
                                "--motion", "random"], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                               text=True)  # fmt: skip
        emu.stdout.readline()  # its port is up
        port = 8600 + os.getpid() % 100
        command = [sys.executable, "-m", "recorder.cli", "record", "--glove", f"serial:{link}", "--task", "pose",
                   "--realtime", "--fps", "30", "--episodes", "100000", "--episode-time-s", str(episode_s),
                   "--reset-time-s", "2", "--view", f"web:{port}", "--root", str(root), "--repo-id", "bench/soak",
                   "--json"]  # fmt: skip
        rec = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=REPO)
        stop = threading.Event()
        page = threading.Thread(target=browser, args=(port, stop), daemon=True)
        page.start()
        lines: list[tuple[float, str]] = []

        def read_lines():
            for line in rec.stderr:
                lines.append((time.monotonic(), line.rstrip()))

        reader = threading.Thread(target=read_lines, daemon=True)
        reader.start()
        proc = psutil.Process(rec.pid)
        t0 = time.monotonic()
        samples, unplugs = [], []
        next_sample, next_unplug = t0, t0 + unplug_every_s
        end = t0 + minutes * 60
        try:
            while time.monotonic() < end:
                now = time.monotonic()
                if rec.poll() is not None:
                    raise RuntimeError(f"gloverec record ended early ({rec.returncode}): {lines[-3:]}")
                if now >= next_sample:
                    samples.append(
                        {"t_s": round(now - t0, 1), **_tree(proc), "log_mb": round(_log_bytes(root) / 2**20, 2)}
                    )
                    next_sample += sample_s
                    print(f"{(now - t0) / 60:5.1f} min", samples[-1], flush=True)
                if now >= next_unplug:
                    emu.send_signal(signal.SIGUSR1)  # the cable pulled ...
                    time.sleep(unplugged_s)  # the harness itself waits; the recorder does not sleep on it
                    emu.send_signal(signal.SIGUSR2)  # ... and put back
                    unplugs.append((round(now - t0, 1), round(time.monotonic() - t0, 1)))
                    next_unplug += unplug_every_s
                    continue
                time.sleep(max(0.0, min(next_sample, next_unplug, end) - time.monotonic()))
        finally:
            rec.send_signal(signal.SIGINT)  # Ctrl-C: what the writer was handed is saved
            out, _ = rec.communicate(timeout=300)
            reader.join(10)
            stop.set()
            page.join(15)
            emu.terminate()
            emu.communicate(timeout=10)
        summary = json.loads(out.strip().splitlines()[-1]) if out.strip() else {}
        return {**_analyse(root, lines, t0, samples, unplugs, episode_s), "summary": summary,
                "minutes": minutes, "unplug_every_s": unplug_every_s, "unplugged_s": unplugged_s}  # fmt: skip


def _analyse(root: Path, lines, t0, samples, unplugs, episode_s) -> dict:
    import numpy as np
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    from recorder.record.sidecar import read_sidecar

    starts = [(int(m[1]), t - t0) for t, s in lines if (m := STARTED.search(s))]
    started = dict(starts)  # an episode lost to the unplugging is recorded again under its index: the last start
    saved_lines = {int(m[1]): int(m[2]) for _, s in lines if (m := SAVED.search(s))}
    discarded = [(round(t - t0, 1), m[2]) for t, s in lines if (m := DISCARDED.search(s))]
    side = {s["episode_index"]: s for s in read_sidecar(root)}
    ds = LeRobotDataset("bench/soak", root=root)
    cols = ds.hf_dataset.with_format("numpy").select_columns(["episode_index", "quality.latency_ms"])
    episode, latency = np.asarray(cols["episode_index"]), np.asarray(cols["quality.latency_ms"])
    n_max = int(round(episode_s * 30))
    loads, lost_frames, missing = [], 0, []
    for index, record in side.items():
        want = record["frames"]
        got = int(np.sum(episode == index))
        meta = ds.meta.episodes[index]
        loads.append(got == want and meta["length"] == want)
        lost_frames += record["glove_dropped"]
        if want < n_max and index != max(side):  # the last one is cut by Ctrl-C
            missing.append(index)
            lost_frames += n_max - want
    windows = []
    for w in range(int(max(started.values(), default=0) // WINDOW_S) + 1):
        eps = [i for i, t in started.items() if w * WINDOW_S <= t < (w + 1) * WINDOW_S and i in side]
        lat = latency[np.isin(episode, eps)]
        lat = lat[lat >= 0]
        if lat.size:
            windows.append({"window": w, "from_min": w * WINDOW_S / 60, "episodes": len(eps),
                            "latency_ms_p50": round(float(np.percentile(lat, 50)), 2),
                            "latency_ms_p99": round(float(np.percentile(lat, 99)), 2)})  # fmt: skip
    first_saved = min((t - t0 for t, s in lines if SAVED.search(s)), default=0.0)
    warm = next((s for s in samples if s["t_s"] >= first_saved), samples[-1])  # the writer and the view are up
    last = samples[-1]
    minutes = (last["t_s"] - samples[0]["t_s"]) / 60 or 1.0
    first_w, last_w = windows[0], windows[-1]
    results = {
        "samples": samples,
        "unplugged": unplugs,
        "discarded": discarded,
        "windows": windows,
        "episodes_recorded": len(starts),
        "episodes_saved": len(side),
        "episodes_in_dataset": ds.meta.total_episodes,
        "episodes_saved_lines": len(saved_lines),
        "episodes_lost_to_unplug": sum("glove went away" in why for _, why in discarded),
        "episodes_cut_by_the_stop": len(starts) - len(side) - len(discarded),  # Ctrl-C drops the one in progress
        "frames": int(episode.size),
        "frames_lost_outside_unplugged": int(lost_frames),
        "short_episodes": missing,
        "glove_late": sum(s["glove_late"] for s in side.values()),
        "loop_overruns": sum(s["loop_overruns"] for s in side.values()),
        "rss_mb": {
            "start": samples[0]["rss_mb"],
            "warm": warm["rss_mb"],
            "end": last["rss_mb"],
            "growth_from_warm": round(last["rss_mb"] - warm["rss_mb"], 1),
            "max": max(s["rss_mb"] for s in samples),
        },  # fmt: skip
        "children_rss_mb": {  # all children together, and each role
            role: {
                "warm": warm.get(key, 0.0),
                "end": last.get(key, 0.0),
                "growth_from_warm": round(last.get(key, 0.0) - warm.get(key, 0.0), 1),
            }
            for key in sorted({k for x in samples for k in x if k.endswith("_rss_mb") and k != "rss_mb"})
            if (role := key.removesuffix("_rss_mb"))
        },  # fmt: skip
        "fds": {"warm": warm["fds"], "end": last["fds"], "max": max(s["fds"] for s in samples)},
        "threads": {"warm": warm["threads"], "end": last["threads"], "max": max(s["threads"] for s in samples)},
        "log_mb": {"end": last["log_mb"], "per_minute": round((last["log_mb"] - samples[0]["log_mb"]) / minutes, 2)},
    }
    results["goals"] = {
        "rss_growth_le_50mb": results["rss_mb"]["growth_from_warm"]
        + results["children_rss_mb"]["children"]["growth_from_warm"]
        <= 50,
        "latency_p99_last_within_20pct_of_first": last_w["latency_ms_p99"] <= 1.2 * first_w["latency_ms_p99"],
        "zero_frames_lost_outside_unplugged": lost_frames == 0,
        "every_saved_episode_loads": all(loads) and len(loads) == ds.meta.total_episodes,
    }
    return results


def plot(results: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    s = results["samples"]
    t = [x["t_s"] / 60 for x in s]
    fig, ax = plt.subplots(1, 3, figsize=(15, 4))
    ax[0].plot(t, [x["rss_mb"] for x in s], label="recording process")
    for role in ("writer", "view"):
        ax[0].plot(t, [x.get(f"{role}_rss_mb", float("nan")) for x in s], label=f"its {role} process")
    ax[0].set(xlabel="minutes", ylabel="RSS (MB)", title="memory")
    ax[1].plot(t, [x["log_mb"] for x in s], color="C2")
    ax[1].set(xlabel="minutes", ylabel="MB", title="session log (MCAP)")
    w = results["windows"]
    ax[2].plot([x["from_min"] + 2.5 for x in w], [x["latency_ms_p50"] for x in w], "o-", label="p50")
    ax[2].plot([x["from_min"] + 2.5 for x in w], [x["latency_ms_p99"] for x in w], "o-", label="p99")
    ax[2].set(xlabel="minutes", ylabel="glove sample -> action (ms)", title="latency per 5-minute window")
    for a in ax:
        for start, stop in results["unplugged"]:
            a.axvspan(start / 60, stop / 60, color="0.85")
    ax[0].legend()
    ax[2].legend()
    fig.suptitle(
        f"{results['minutes']:g} min of `gloverec record --realtime --fps 30 --view web` (grey: glove unplugged)"
    )
    fig.tight_layout()
    fig.savefig(path, dpi=80)
    print(f"wrote {path}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--minutes", type=float, default=60.0)
    ap.add_argument("--unplug-every-s", type=float, default=300.0)
    ap.add_argument("--unplugged-s", type=float, default=10.0)
    ap.add_argument("--sample-s", type=float, default=10.0)
    ap.add_argument("--episode-s", type=float, default=20.0, help="each episode's length (then a 2 s reset)")
    args = ap.parse_args()
    results = soak(args.minutes, args.unplug_every_s, args.unplugged_s, args.sample_s, args.episode_s)
    write_results("soak", results)
    plot(results, REPO / "docs" / "images" / "soak.png")
    print(json.dumps({k: v for k, v in results.items() if k not in ("samples", "windows")}, indent=1))


if __name__ == "__main__":
    main()
