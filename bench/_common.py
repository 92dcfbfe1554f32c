"""Shared by the benchmarks: where results go and how they are written, and a browser on the web view."""

from __future__ import annotations

import json
import math
import platform
import statistics
import sys
import time
from pathlib import Path

BENCH = Path(__file__).resolve().parent
RESULTS = BENCH / "results"
REPO = BENCH.parent

# `python bench/X.py` puts bench/ first on sys.path, where bench/envs.py would shadow the `envs` package:
# benchmarks import this module first, and it puts the repository first instead.
sys.path[:] = [p for p in sys.path if Path(p or ".").resolve() != BENCH]
sys.path.insert(0, str(REPO))


def write_results(name: str, results: dict) -> Path:
    RESULTS.mkdir(parents=True, exist_ok=True)
    path = RESULTS / f"{name}.json"
    meta = {
        "benchmark": name,
        "when": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
        "python": platform.python_version(),
        "machine": platform.machine(),
        "cpus": __import__("os").cpu_count(),
    }
    path.write_text(json.dumps({"meta": meta, **results}, indent=2) + "\n")
    print(f"wrote {path}")
    return path


def merged_with_previous(name: str, results: dict) -> dict:
    """``results`` (sections of rows keyed "task/robot..."), after the rows of bench/results/<name>.json that this
    run did not measure: a run on a subset updates its rows and keeps the others. Section "measured" says when
    each row was measured."""
    path = RESULTS / f"{name}.json"
    old = json.loads(path.read_text()) if path.exists() else {}
    then, now = old.get("meta", {}).get("when"), time.strftime("%Y-%m-%dT%H:%M:%S%z")
    measured = dict(old.get("measured", {}))
    out = {}
    for section, rows in results.items():
        if not isinstance(rows, dict):
            out[section] = rows
            continue
        kept = {k: v for k, v in old.get(section, {}).items() if k not in rows}
        for k in kept:
            measured.setdefault(f"{section}:{k}", then)
        for k in rows:
            measured[f"{section}:{k}"] = now
        out[section] = {**kept, **rows}
    return {**out, "measured": dict(sorted(measured.items()))}


def median_rate(fn, items: int, runs: int = 5) -> dict:
    """Run ``fn`` ``runs`` times; items per second as median, min and max."""
    rates = []
    for _ in range(runs):
        t = time.perf_counter()
        fn()
        rates.append(items / (time.perf_counter() - t))
    return {"median": round(statistics.median(rates)), "min": round(min(rates)), "max": round(max(rates)), "runs": runs}


def gloverec(*args: str, timeout: float = 3600) -> dict:
    """A gloverec command with --json in a child process, as a user runs it: its JSON object (a failure ends the
    benchmark with the command's error)."""
    import subprocess

    cmd = [sys.executable, "-m", "recorder.cli", *args, "--json"]
    print("  $ gloverec " + " ".join(args), flush=True)
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)
    if r.returncode != 0:
        sys.exit(f"bench: `gloverec {' '.join(args)}` failed: {r.stderr.strip()[-2000:]}")
    return json.loads(r.stdout.strip().splitlines()[-1])


def wilson(successes: int, n: int, z: float = 1.96) -> list[float]:
    """The Wilson score interval of a success rate (Wilson 1927), as [low, high]."""
    if n == 0:
        return [0.0, 1.0]
    p = successes / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    return [max(0.0, round(centre - half, 3)), min(1.0, round(centre + half, 3))]  # no -0.0 at 0 of n


# LeRobot's ACT, small enough to train on this 2-core CPU in minutes (bench/learning.py, bench/human_demos.py)
ACT_FLAGS = [
    "--policy.type=act",
    "--policy.device=cpu",
    "--policy.push_to_hub=false",
    "--policy.dim_model=256",
    "--policy.dim_feedforward=1024",
    "--policy.n_encoder_layers=2",
    "--policy.n_vae_encoder_layers=2",
    "--policy.chunk_size=10",
    "--policy.n_action_steps=1",
    "--policy.temporal_ensemble_coeff=0.01",
    "--policy.optimizer_lr=1e-4",
    "--batch_size=32",
    "--num_workers=0",
    "--env_eval_freq=0",
    "--log_freq=500",
]


def train_act(repo_id: str, root: Path, out: Path, steps: int) -> tuple[str, float, str | None]:
    """`lerobot-train` ACT on a dataset folder, as a user runs it: (the command, seconds, its error or None)."""
    import os
    import subprocess

    train = str(Path(sys.executable).with_name("lerobot-train"))
    cmd = [train, f"--dataset.repo_id={repo_id}", f"--dataset.root={root}", *ACT_FLAGS, f"--steps={steps}",
           f"--save_freq={steps}", f"--output_dir={out}"]  # fmt: skip
    command = "lerobot-train " + " ".join(cmd[1:])
    print("  $ " + command, flush=True)
    t = time.perf_counter()
    r = subprocess.run(cmd, capture_output=True, text=True, env={**os.environ, "OMP_NUM_THREADS": "1"})
    return command, time.perf_counter() - t, (r.stderr.strip()[-1500:] if r.returncode != 0 else None)


def browser(port: int, stop, as_invoker: bool = False) -> None:
    """Headless Chromium on the web view's page, from when it is up until ``stop`` is set; as an unprivileged user
    unless ``as_invoker`` (then as whoever runs the benchmark, as `gloverec record`'s user would open the page)."""
    import os
    import shutil
    import socket
    import subprocess
    import tempfile

    while not stop.is_set():
        try:
            socket.create_connection(("127.0.0.1", port), 0.2).close()
            break
        except OSError:
            time.sleep(0.2)
    with tempfile.TemporaryDirectory() as profile:
        os.chmod(profile, 0o777)
        # as an unprivileged user, like a person's browser: as root, Chromium raises its own processes' priority
        # (nice -8) above the recording's, which no browser of a normal user can do
        user = ["setpriv", "--reuid=65534", "--regid=65534", "--clear-groups"] if os.geteuid() == 0 else []
        user = [] if as_invoker else user
        proc = subprocess.Popen(
            [*user, shutil.which("chromium"), "--headless=new", "--no-sandbox", "--disable-gpu",
             "--disable-background-networking", "--no-first-run", "--disable-component-update", "--disable-sync",
             f"--user-data-dir={profile}",
             f"http://127.0.0.1:{port}/"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
            env={**os.environ, "HOME": profile})  # fmt: skip
        stop.wait()
        proc.kill()
        proc.wait(10)
