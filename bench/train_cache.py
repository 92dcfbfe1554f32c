"""`gloverec train` from the frame cache in memory and on disk (policies/diskcache.py): training steps per second
on the same camera dataset, and the peak resident memory of the whole run as the dataset grows 3x.

    python bench/train_cache.py [--small DIR --large DIR]   (two `gloverec record --cameras front,top` datasets,
                                                             the large one 3x the small one's episodes; without
                                                             them: 12 and 36 episodes of grasp, recorded first)

Each run is a child process (its peak RSS its own: VmHWM), training gloverec_bc on every episode (no validation
split, so the steps are all that is timed) with one torch thread, as `gloverec train` does by default. Memory and disk
runs alternate (A, B, A, B) so that other load on the machine hits both alike. The disk cache is built by a first,
untimed run; building it costs one decoding pass, as loading into memory does. For comparison: what LeRobot's
per-item loading (its map-style and streaming datasets alike, each frame's videos decoded when drawn) costs a batch.
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import time
from pathlib import Path

import _common  # noqa: F401  (puts the repository first on sys.path)
from _common import write_results


def child(where: str, root: str, steps: int, batch: int, out: str) -> None:
    """One training run; prints its steps per second, peak RSS and, at its end, anonymous and file-backed RSS."""
    import torch

    from policies import train as train_mod
    from policies.config import TrainConfig
    from policies.data import FrameCache, resolve

    torch.set_num_threads(1)
    timed = {"save": 0.0}
    loop, save = train_mod._loop, train_mod._save

    def timed_loop(*args, **kw):  # the steps only: not the decoding, not the policy's construction
        t = time.perf_counter()
        loop(*args, **kw)
        timed["loop"] = time.perf_counter() - t

    def timed_save(*args, **kw):  # nor the checkpoint (and its loss plot), the same for both caches
        t = time.perf_counter()
        save(*args, **kw)
        timed["save"] += time.perf_counter() - t

    assemble, batches = FrameCache.batch, []

    def timed_batch(self, indices):  # assembling a batch: where the two caches differ
        t = time.perf_counter()
        out = assemble(self, indices)
        batches.append(time.perf_counter() - t)
        return out

    train_mod._loop, train_mod._save, FrameCache.batch = timed_loop, timed_save, timed_batch
    cfg = TrainConfig.load(steps=steps, batch_size=batch, val_fraction=0.0, save_every=steps, frame_cache=where)
    train_mod.train(resolve(f"bench/{Path(root).name}", root=root), out, cfg, progress=False)
    status = dict(line.split(":", 1) for line in Path("/proc/self/status").read_text().splitlines())
    mb = {k: round(int(status[k].split()[0]) / 1024) for k in ("VmHWM", "RssAnon", "RssFile")}
    print(
        json.dumps(
            {
                "steps_per_s": steps / (timed["loop"] - timed["save"]),
                "peak_rss_mb": mb["VmHWM"],
                "end_anon_mb": mb["RssAnon"],
                "end_file_mb": mb["RssFile"],
                "batch_ms": round(1000 * statistics.median(batches), 2),
            }
        )
    )


def run(where: str, root: Path, steps: int, batch: int, tmp: Path) -> dict:
    out = tmp / f"run{time.monotonic_ns()}"
    cmd = [sys.executable, __file__, "--child", where, str(root), str(steps), str(batch), str(out)]
    t = time.perf_counter()
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(f"bench: the {where} run failed: {r.stderr.strip()[-2000:]}")
    result = json.loads(r.stdout.strip().splitlines()[-1])
    result["wall_s"] = round(time.perf_counter() - t, 1)
    print(f"  {where:6s} {root.name}: {result}", flush=True)
    return result


def lerobot_batch_s(root: Path, batch: int) -> float:
    """Seconds for ``batch`` random frames through LeRobotDataset's __getitem__ (videos decoded per item)."""
    import torch
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    from recorder.video_backend import video_backend

    ds = LeRobotDataset(f"bench/{Path(root).name}", root=root, video_backend=video_backend())
    picked = torch.randint(len(ds), (batch,), generator=torch.Generator().manual_seed(0)).tolist()
    ds[picked[0]]  # the decoder opened
    t = time.perf_counter()
    for i in picked:
        ds[i]
    return time.perf_counter() - t


def frames(root: Path) -> int:
    return json.loads((root / "meta" / "info.json").read_text())["total_frames"]


def main() -> None:
    if len(sys.argv) > 1 and sys.argv[1] == "--child":
        child(sys.argv[2], sys.argv[3], int(sys.argv[4]), int(sys.argv[5]), sys.argv[6])
        return
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--small", type=Path, help="the 1x dataset (default: 12 episodes of grasp, recorded in --tmp)")
    p.add_argument("--large", type=Path, help="the 3x dataset (default: 36 episodes of grasp, recorded in --tmp)")
    p.add_argument("--steps", type=int, default=30)
    p.add_argument("--batch-size", type=int, default=64)
    p.add_argument("--pairs", type=int, default=2, help="memory/disk pairs timed on the small dataset")
    p.add_argument("--tmp", type=Path, default=Path("/tmp/gloverec-bench-train-cache"))
    args = p.parse_args()
    import shutil

    shutil.rmtree(args.tmp, ignore_errors=True)
    args.tmp.mkdir(parents=True)
    for name, episodes in (("small", 12), ("large", 36)):
        if getattr(args, name) is None:  # make bench: the datasets the figures in docs/policies.md came from
            root = args.tmp / f"grasp{episodes}"
            subprocess.run([sys.executable, "-m", "recorder.cli", "record", "--glove", "emulator", "--task", "grasp",
                            "--cameras", "front,top", "--episodes", str(episodes), "--fast", "--no-log",
                            "--repo-id", f"bench/grasp{episodes}", "--root", str(root), "--view", "none"],
                           check=True)  # fmt: skip
            setattr(args, name, root)
    s, b = args.steps, args.batch_size
    for d in (args.small, args.large):  # built afresh, so that the first run's time is a build's
        shutil.rmtree(d / ".cache" / "frames", ignore_errors=True)
    print("building the disk caches (untimed)", flush=True)
    built = {d.name: run("disk", d, 1, b, args.tmp)["wall_s"] for d in (args.small, args.large)}
    runs: dict[str, list] = {"memory": [], "disk": []}
    for _ in range(args.pairs):
        for where in ("memory", "disk"):
            runs[where].append(run(where, args.small, s, b, args.tmp))
    large = {"disk": [], "memory": []}
    for where in ("disk", "memory", "disk"):  # the memory run at 3x is the slow one: once
        large[where].append(run(where, args.large, s, b, args.tmp))
    rate = {w: statistics.median(r["steps_per_s"] for r in runs[w]) for w in runs}
    rss = {w: {n: statistics.median(r["peak_rss_mb"] for r in rs[w]) for n, rs in (("1x", runs), ("3x", large))}
           for w in runs}  # fmt: skip
    write_results(
        "train_cache",
        {
            "dataset": {
                "small_frames": frames(args.small),
                "large_frames": frames(args.large),
                "cameras": "front,top at 128 x 128",
                "policy": "gloverec_bc, one torch thread",
            },  # fmt: skip
            "settings": {"steps": s, "batch_size": b, "pairs": args.pairs},
            "steps_per_s": {w: [round(r["steps_per_s"], 2) for r in runs[w]] for w in runs},
            "steps_per_s_median": {w: round(v, 2) for w, v in rate.items()},
            "batch_ms_median": {w: statistics.median(r["batch_ms"] for r in runs[w]) for w in runs},
            "disk_over_memory": round(rate["disk"] / rate["memory"], 3),
            "peak_rss_mb": rss,
            "disk_rss_3x_over_1x": round(rss["disk"]["3x"] / rss["disk"]["1x"], 3),
            "memory_rss_3x_over_1x": round(rss["memory"]["3x"] / rss["memory"]["1x"], 3),
            "disk_cache_first_run_wall_s": built,  # a 1-step run: imports, policy, the build
            "memory_run_wall_s": {"1x": [r["wall_s"] for r in runs["memory"]], "3x": large["memory"][0]["wall_s"]},
            "runs": {"1x": runs, "3x": large},
            "lerobot_per_item_s_per_batch": round(lerobot_batch_s(args.small, b), 2),
            "note": "a shared 2-core machine: other jobs ran alongside; memory and disk runs interleaved",
        },
    )


if __name__ == "__main__":
    main()
