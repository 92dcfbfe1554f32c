"""`gloverec review` on 100 HandGrasp episodes (glovehand, no cameras, in the hub): seconds from starting the
command to the first episode's first frame shown in headless Chromium (the browser already running), and seconds
the page's Publish takes after 10 episodes are discarded (the hub's next version). Medians of 3 runs, each on a
fresh hub. Writes bench/results/review.json.

    python bench/review.py [--runs 3] [--data /tmp/gloverec-bench/grasp100]
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
import urllib.request
from pathlib import Path

from _common import gloverec, write_results

REPO_ID = "bench/grasp100"
EPISODES = 100


def dataset(root: Path) -> Path:
    """The 100-episode recording, made once and kept (about 2 minutes here)."""
    info = root / "meta" / "info.json"
    if info.exists() and json.loads(info.read_text())["total_episodes"] == EPISODES:
        return root
    shutil.rmtree(root, ignore_errors=True)
    gloverec("record", "--view", "none", "--glove", "emulator", "--task", "grasp", "--robot", "glovehand",
             "--episodes", str(EPISODES), "--fast", "--no-log", "--reset-time-s", "0", "--root", str(root),
             "--repo-id", REPO_ID)  # fmt: skip
    return root


def browser():
    from selenium import webdriver
    from selenium.webdriver.chrome.options import Options
    from selenium.webdriver.chrome.service import Service

    options = Options()
    for flag in ("--headless=new", "--no-sandbox", "--disable-gpu", "--no-first-run", "--window-size=1400,900"):
        options.add_argument(flag)
    options.binary_location = shutil.which("chromium") or "/usr/bin/chromium"
    return webdriver.Chrome(options=options, service=Service(shutil.which("chromedriver")))


def post(url: str, body: dict) -> dict:
    req = urllib.request.Request(url, json.dumps(body).encode(), {"Content-Type": "application/json"})
    with urllib.request.urlopen(req, timeout=600) as r:
        return json.loads(r.read())


def run_once(data: Path, page) -> dict:
    with tempfile.TemporaryDirectory(prefix="gloverec-bench-review-") as tmp:
        hub = Path(tmp) / "hub"
        gloverec("push", "--repo-id", REPO_ID, "--root", str(data), "--hub", str(hub))
        t0 = time.time()
        cmd = [sys.executable, "-m", "recorder.cli", "review", "--repo-id", REPO_ID, "--hub", str(hub)]
        proc = subprocess.Popen([*cmd, "--http-port", "0", "--no-browser"], stdout=subprocess.PIPE, text=True)
        try:
            line = proc.stdout.readline()
            url_s = time.time() - t0
            if not line.startswith("review: "):
                sys.exit(f"bench: gloverec review did not start: {line!r}")
            url = line.split(" ", 1)[1].strip()
            page.get(url)
            shown = None
            while shown is None and time.time() - t0 < 60:
                shown = page.execute_script("return document.body.dataset.firstFrame")
                time.sleep(0.01)
            first_s = int(shown) / 1000 - t0
            for e in range(0, EPISODES, EPISODES // 10):  # 10 episodes discarded: 0, 10, ..., 90
                post(url + "api/edit", {"episode": e, "op": "discard"})
            t = time.perf_counter()
            result = post(url + "api/publish", {})["result"]
            publish_s = time.perf_counter() - t
        finally:
            proc.terminate()
            proc.wait(10)
        assert result["episodes"] == EPISODES - 10 and result["version"] == "v2", result
        verified = subprocess.run([sys.executable, "-m", "recorder.cli", "hub", "verify", "--hub", str(hub)],
                                  capture_output=True, text=True)  # fmt: skip
        assert verified.returncode == 0, verified.stderr
        return {"url_s": url_s, "first_frame_s": first_s, "publish_s": publish_s, "frames": result["frames"]}


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--runs", type=int, default=3)
    p.add_argument("--data", default="/tmp/gloverec-bench/grasp100", help="the 100-episode recording (made if absent)")
    args = p.parse_args()
    os.environ.setdefault("MUJOCO_GL", "egl")
    os.environ.setdefault("HF_HUB_OFFLINE", "1")
    data = dataset(Path(args.data))
    page = browser()
    try:
        runs = []
        for k in range(args.runs):
            runs.append(run_once(data, page))
            print(f"  run {k}: " + ", ".join(f"{n} {v:.2f}" for n, v in runs[-1].items()), flush=True)
    finally:
        page.quit()

    def median(key: str) -> float:
        return round(statistics.median(r[key] for r in runs), 2)

    write_results("review", {
        "dataset": {"task": "grasp", "robot": "glovehand", "episodes": EPISODES, "cameras": 0, "where": "hub"},
        "open_to_first_frame_s": median("first_frame_s"),
        "open_to_url_s": median("url_s"),
        "publish_after_deleting_10_s": median("publish_s"),
        "published_frames": runs[0]["frames"],
        "runs": [{k: round(v, 2) for k, v in r.items()} for r in runs],
        "goals": {"open_to_first_frame_s": 3.0, "publish_after_deleting_10_s": 20.0},
    })  # fmt: skip


if __name__ == "__main__":
    main()
