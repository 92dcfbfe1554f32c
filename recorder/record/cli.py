"""`gloverec record`: flags over configs/record/default.yaml (or --config FILE)."""

from __future__ import annotations

import argparse
import json


def add_parsers(sub) -> None:
    r = sub.add_parser("record", help="record demonstrations from a glove into a LeRobot dataset")
    r.add_argument("--config", help="a record YAML (default: configs/record/default.yaml)")
    r.add_argument("--glove", help="emulator, serial:PORT (or a path), udp:PORT or mcap:FILE")
    r.add_argument("--robot", help="a robot of configs/robots/ (glovehand, shadow)")
    r.add_argument("--task", help="pose or grasp")
    r.add_argument("--fps", type=int, help="dataset frames per second (default 30)")
    r.add_argument("--episodes", type=int, help="episodes to save")
    r.add_argument("--episode-time-s", type=float, help="longest episode (default: the task's)")
    r.add_argument("--reset-time-s", type=float, help="pause between episodes (default 2)")
    r.add_argument("--repo-id", help="USER/NAME")
    r.add_argument("--root", help="dataset folder (default datasets/recordings/USER/NAME)")
    r.add_argument("--resume", action="store_true", default=None, help="add episodes to an existing recording")
    r.add_argument("--cameras", type=lambda s: [c for c in s.split(",") if c],
                   help="comma-separated cameras to record (front, top, side)")
    pace = r.add_mutually_exclusive_group()
    pace.add_argument("--realtime", dest="realtime", action="store_true", default=None,
                      help="wall-clock pacing (default for serial and UDP gloves)")
    pace.add_argument("--fast", dest="realtime", action="store_false",
                      help="as fast as the glove delivers (default for the emulator and logs)")
    r.add_argument("--retarget", choices=("joint", "ik"))
    r.add_argument("--seed", type=int)
    r.add_argument("--glove-rate", dest="glove_rate_hz", type=float, help="the emulator's rate (Hz)")
    r.add_argument("--glove-mode", choices=("pose", "raw"), help="the emulator's output (raw: host fusion)")
    r.add_argument("--task-text", help="the task string stored with every frame")
    r.add_argument("--no-log", dest="log", action="store_false", default=None, help="no raw MCAP log")
    r.add_argument("--json", action="store_true", help="print a JSON summary at the end")
    r.set_defaults(func=run_record)


def run_record(args: argparse.Namespace) -> int:
    from recorder.record.config import RecordConfig
    from recorder.record.recorder import record

    keys = ("glove", "robot", "task", "fps", "episodes", "episode_time_s", "reset_time_s", "repo_id", "root",
            "resume", "cameras", "realtime", "retarget", "seed", "glove_rate_hz", "glove_mode", "task_text", "log")
    cfg = RecordConfig.load(args.config, **{k: getattr(args, k) for k in keys})
    summary = record(cfg)
    if args.json:
        print(json.dumps(summary))
    else:
        print(f"{summary['episodes_saved']} episode(s) saved; {summary['root']} now holds "
              f"{summary['total_episodes']} episodes, {summary['total_frames']} frames "
              f"(LeRobotDataset({summary['repo_id']!r}, root={summary['root']!r}))")
    return 0
