"""The kill anchor: what survives a SIGKILL after ten saved episodes, LeRobot's own recording against gloverec's
crash-safe store (recorder/record/store.py), on the lerobot installed here.

A child process records small state-only episodes (as lerobot-record writes them: ``LeRobotDataset.create``,
``add_frame``, ``save_episode``, with the finalize() at the end that a kill never reaches; or through
``EpisodeStore``) and prints each save; the parent SIGKILLs it once the tenth is saved, then loads the folder
with plain ``LeRobotDataset``: the episodes and frames that load, or the error. Several runs (the kill lands at
different moments of the eleventh episode); writes bench/results/kill_anchor.json.

    .venv/bin/python bench/kill_anchor.py [--runs 3]
"""

from __future__ import annotations

import argparse
import json
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from bench._common import write_results  # noqa: E402

FEATURES = {
    "observation.state": {"dtype": "float32", "shape": (8,), "names": [f"s{i}" for i in range(8)]},
    "action": {"dtype": "float32", "shape": (8,), "names": [f"a{i}" for i in range(8)]},
}
CHILD = """
import sys, numpy as np, json
features = {k: {**v, "shape": tuple(v["shape"])} for k, v in json.loads(sys.argv[3]).items()}
root, kind = sys.argv[1], sys.argv[2]
if kind == "lerobot":
    from lerobot.datasets.lerobot_dataset import LeRobotDataset
    ds = LeRobotDataset.create("bench/kill", 30, features, root=root, robot_type="none", use_videos=False)
    add, save = ds.add_frame, ds.save_episode
else:
    from recorder.record.store import EpisodeStore
    store = EpisodeStore(root, "bench/kill", 30, features, "none", use_videos=False)
    add, save = store.add_frame, (lambda: store.save_episode({"marker": 0}))
e = 0
while True:
    for i in range(60):
        add({"observation.state": np.full(8, e + i / 100, np.float32), "action": np.full(8, e, np.float32),
             "task": "reach"})
    save()
    e += 1
    print("saved", e, flush=True)
"""


def one(kind: str, tmp: Path, episodes: int) -> dict:
    root = tmp / f"{kind}-{time.monotonic_ns()}"
    feats = {k: {**v, "shape": list(v["shape"])} for k, v in FEATURES.items()}
    proc = subprocess.Popen([sys.executable, "-c", CHILD, str(root), kind, json.dumps(feats)],
                            stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)  # fmt: skip
    for line in proc.stdout:
        if line.strip() == f"saved {episodes}":
            break
    time.sleep(0.05)  # into the next episode's frames
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    saved = episodes + sum(1 for line in proc.stdout if line.startswith("saved"))  # printed before the kill landed
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    try:
        ds = LeRobotDataset("bench/kill", root=root)
        return {"saved": saved, "loads": True, "episodes": ds.num_episodes, "frames": ds.num_frames}
    except Exception as exc:  # noqa: BLE001  (what a user meets, whatever lerobot raises)
        return {
            "saved": saved,
            "loads": False,
            "episodes": 0,
            "error": f"{type(exc).__name__}: {str(exc).splitlines()[0][:200]}",
        }


def main() -> None:
    import lerobot

    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--runs", type=int, default=3)
    p.add_argument("--episodes", type=int, default=10)
    args = p.parse_args()
    out = {"lerobot": lerobot.__version__, "saved_before_kill": args.episodes}
    with tempfile.TemporaryDirectory(prefix="gloverec-kill-") as tmp:
        for kind in ("lerobot", "gloverec"):
            runs = [one(kind, Path(tmp), args.episodes) for _ in range(args.runs)]
            out[kind] = {"runs": runs, "episodes_kept_min": min(r["episodes"] for r in runs)}
            error = "" if runs[0]["loads"] else f"; {runs[0]['error']}"
            print(f"{kind} (lerobot {lerobot.__version__}): episodes saved before the kill "
                  f"{[r['saved'] for r in runs]}, that load after it {[r['episodes'] for r in runs]}{error}",
                  flush=True)  # fmt: skip
    write_results("kill_anchor", out)


if __name__ == "__main__":
    main()
