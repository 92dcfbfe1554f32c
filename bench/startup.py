"""Start-up benchmark: how long a person waits after Enter, for the first recorded frame and for the one-line error
of a bad path, file or dataset.

    .venv/bin/python bench/startup.py [--runs 5]

First frame: `gloverec record --glove emulator --realtime --reset-time-s 0` (the emulated glove paced as a real
one, the episode starting at its first hand pose) with `--view none` and with `--view web`, on a pseudo-terminal:
the first frame is when the status line `episode 0  frame 1/N` appears, which the recorder prints as that frame is
stored. Errors: each command's wall time to its one-line `gloverec: error:` (exit 1). Median, min and max of --runs
runs each, from a warm disk cache (one unmeasured run first). Goals: first frame <= 5 s with --view none and
<= 8 s with --view web; every error <= 3 s.
"""

from __future__ import annotations

import argparse
import os
import pty
import select
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import REPO, write_results  # noqa: E402

FIRST_FRAME = b"frame 1/"
GOALS = {"first_frame_view_none_s": 5.0, "first_frame_view_web_s": 8.0, "error_s": 3.0}


def _env() -> dict:
    # this tree's recorder, not an installed one
    return {**os.environ, "PYTHONPATH": str(REPO), "MUJOCO_GL": "egl", "HF_HUB_OFFLINE": "1"}


def first_frame(args: list[str], timeout: float = 120.0) -> float:
    """Seconds from starting `gloverec ARGS` on a terminal to its status line of frame 1; the command is then
    interrupted (Ctrl-C, as a person would)."""
    master, slave = pty.openpty()
    t = time.perf_counter()
    proc = subprocess.Popen([sys.executable, "-m", "recorder.cli", *args], stdin=subprocess.DEVNULL, stdout=slave,
                            stderr=slave, env=_env(), cwd=REPO)  # fmt: skip
    os.close(slave)
    seen, elapsed = b"", None
    try:
        while time.perf_counter() - t < timeout:
            ready, _, _ = select.select([master], [], [], 0.05)
            if ready:
                try:
                    seen += os.read(master, 65536)
                except OSError:  # the command ended
                    break
                if FIRST_FRAME in seen:
                    elapsed = time.perf_counter() - t
                    break
            elif proc.poll() is not None:
                break
    finally:
        proc.send_signal(2)
        try:
            proc.wait(30)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
        os.close(master)
    if elapsed is None:
        sys.exit(f"bench: `gloverec {' '.join(args)}` recorded no frame: {seen.decode(errors='replace')[-1500:]}")
    return elapsed


def error_time(args: list[str]) -> tuple[float, str]:
    """Seconds to the one-line error of `gloverec ARGS`, and the line."""
    t = time.perf_counter()
    r = subprocess.run([sys.executable, "-m", "recorder.cli", *args], capture_output=True, text=True, env=_env(),
                       cwd=REPO, timeout=300)  # fmt: skip
    elapsed = time.perf_counter() - t
    lines = [ln for ln in r.stderr.splitlines() if ln.startswith("gloverec: error:")]
    if r.returncode != 1 or not lines:
        sys.exit(f"bench: `gloverec {' '.join(args)}` did not fail with one line (exit {r.returncode}): {r.stderr}")
    return elapsed, lines[-1]


def stats(times: list[float]) -> dict:
    return {"median": round(statistics.median(times), 2), "min": round(min(times), 2), "max": round(max(times), 2),
            "runs": len(times)}  # fmt: skip


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=5)
    a = ap.parse_args()
    tmp = Path(tempfile.mkdtemp(prefix="gloverec-startup-"))
    (tmp / "not_a_dataset").mkdir()
    (tmp / "not_a_policy").mkdir()
    (tmp / "hub").mkdir()
    record = ["record", "--glove", "emulator", "--robot", "glovehand", "--task", "pose", "--episodes", "1",
              "--realtime", "--reset-time-s", "0", "--repo-id", "bench/startup", "--no-log"]  # fmt: skip

    def bad_record(root: str, *flags: str) -> list[str]:
        """A recording that must fail at once: ``flags`` replace the emulated glove or add what is wrong."""
        return [*record, "--root", str(tmp / root), "--view", "none", *flags]

    errors = {
        "record_missing_port": bad_record("ds_port", "--glove", "serial:/dev/nonexistent"),
        "record_missing_log": bad_record("ds_log", "--glove", f"mcap:{tmp}/missing.mcap"),
        "record_missing_policy": bad_record("ds_policy", "--policy", str(tmp / "missing_policy")),
        "record_not_a_policy": bad_record("ds_policy", "--policy", str(tmp / "not_a_policy")),
        "record_resume_not_a_recording": [*record, "--root", str(tmp / "not_a_dataset"), "--view", "none", "--resume"],
        "eval_missing_policy": ["eval", "--policy", str(tmp / "missing_policy"), "--episodes", "1"],
        "eval_not_a_policy": ["eval", "--policy", str(tmp / "not_a_policy"), "--episodes", "1"],
        "train_not_a_dataset": [
            "train",
            "--repo-id",
            "bench/startup",
            "--root",
            str(tmp / "not_a_dataset"),
            "--steps",
            "1",
            "--out",
            str(tmp / "train"),
        ],  # fmt: skip
        "train_missing_dataset": [
            "train",
            "--repo-id",
            "bench/missing",
            "--hub",
            str(tmp / "hub"),
            "--steps",
            "1",
            "--out",
            str(tmp / "train"),
        ],  # fmt: skip
        "replay_not_a_dataset": [
            "replay",
            "--repo-id",
            "bench/startup",
            "--root",
            str(tmp / "not_a_dataset"),
            "--episode",
            "0",
        ],  # fmt: skip
        "inspect_missing_dataset": ["inspect", "--repo-id", "bench/startup", "--root", str(tmp / "missing")],
    }
    results: dict = {"first_frame_s": {}, "error_s": {}, "error_line": {}}
    for view in ("none", "web"):
        runs = []
        for i in range(a.runs + 1):  # the first run warms the disk cache
            args = [*record, "--root", str(tmp / f"ds_{view}_{i}"), "--view", view]
            print(f"  $ gloverec {' '.join(args)}", flush=True)
            t = first_frame(args)
            print(f"    first frame after {t:.2f} s", flush=True)
            runs.append(t) if i else None
        results["first_frame_s"][f"view_{view}"] = stats(runs)
    for name, args in errors.items():
        runs = []
        for i in range(a.runs + 1):
            t, line = error_time(args)
            runs.append(t) if i else None
        print(f"  {name}: {statistics.median(runs):.2f} s: {line}", flush=True)
        results["error_s"][name] = stats(runs)
        results["error_line"][name] = line
    worst = max(r["median"] for r in results["error_s"].values())
    results["goals"] = {
        **GOALS,
        "met": {
            "first_frame_view_none": results["first_frame_s"]["view_none"]["median"]
            <= GOALS["first_frame_view_none_s"],
            "first_frame_view_web": results["first_frame_s"]["view_web"]["median"] <= GOALS["first_frame_view_web_s"],
            "errors": worst <= GOALS["error_s"],
        },
    }
    write_results("startup", results)


if __name__ == "__main__":
    main()
