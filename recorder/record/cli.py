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
    r.add_argument(
        "--cameras",
        type=lambda s: [c for c in s.split(",") if c],
        help="comma-separated cameras to record (front, top, side)",
    )
    pace = r.add_mutually_exclusive_group()
    pace.add_argument(
        "--realtime",
        dest="realtime",
        action="store_true",
        default=None,
        help="wall-clock pacing (default for serial and UDP gloves)",
    )
    pace.add_argument(
        "--fast",
        dest="realtime",
        action="store_false",
        help="as fast as the glove delivers (default for the emulator and logs)",
    )
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

    keys = (
        "glove",
        "robot",
        "task",
        "fps",
        "episodes",
        "episode_time_s",
        "reset_time_s",
        "repo_id",
        "root",
        "resume",
        "cameras",
        "realtime",
        "retarget",
        "seed",
        "glove_rate_hz",
        "glove_mode",
        "task_text",
        "log",
    )
    cfg = RecordConfig.load(args.config, **{k: getattr(args, k) for k in keys})
    summary = record(cfg)
    if args.json:
        print(json.dumps(summary))
    else:
        print(
            f"{summary['episodes_saved']} episode(s) saved; {summary['root']} now holds "
            f"{summary['total_episodes']} episodes, {summary['total_frames']} frames "
            f"(LeRobotDataset({summary['repo_id']!r}, root={summary['root']!r}))"
        )
    return 0


def add_rerecord_parser(sub) -> None:
    r = sub.add_parser("rerecord", help="rebuild a dataset from a session's MCAP log with other settings")
    r.add_argument("--log", required=True, help="a session log (<root>/logs/session-*.mcap)")
    r.add_argument("--repo-id", required=True, help="USER/NAME of the new dataset")
    r.add_argument("--root", help="new dataset folder (default datasets/recordings/USER/NAME)")
    r.add_argument("--robot", help="default: the log's robot")
    r.add_argument("--task", help="default: the log's task")
    r.add_argument("--fps", type=int, help="default: the log's")
    r.add_argument("--retarget", choices=("joint", "ik"))
    r.add_argument("--cameras", type=lambda s: [c for c in s.split(",") if c])
    r.add_argument("--json", action="store_true")
    r.set_defaults(func=run_rerecord)


def run_rerecord(args: argparse.Namespace) -> int:
    from recorder import GloverecError
    from recorder.log.playback import read_log
    from recorder.record.config import RecordConfig
    from recorder.record.recorder import Recorder

    info = read_log(args.log)  # a missing, foreign or damaged file: one-line GloverecError
    session = info.metadata.get("gloverec.session", {})
    plan = [
        (m["fields"]["seed"], m["fields"]["device_start_s"], m["fields"]["frames"])
        for m in info.marks
        if m["name"] == "episode_end" and m["fields"].get("device_start_s") is not None
    ]
    if not plan:
        raise GloverecError(f"{args.log} holds no re-recordable episodes (no episode marks with device times)")
    if any(p[1] < 0 for p in plan):
        raise GloverecError(f"{args.log} comes from a glove without a device clock: its episodes cannot be re-timed")
    cfg = RecordConfig.load(
        glove=f"mcap:{args.log}",
        repo_id=args.repo_id,
        root=args.root,
        robot=args.robot or session.get("robot"),
        task=args.task or session.get("task"),
        fps=args.fps or int(session.get("fps", 30)),
        retarget=args.retarget,
        cameras=args.cameras,
        realtime=False,
        episodes=len(plan),
        log=False,
    )
    summary = Recorder(cfg, plan=plan).run()
    summary["source_log"] = args.log
    print(
        json.dumps(summary)
        if args.json
        else f"re-recorded {summary['episodes_saved']} of {len(plan)} episode(s) from {args.log} into {summary['root']}"
    )
    return 0
