"""`gloverec record` and `gloverec rerecord`: flags generated from RecordConfig (recorder/record/config.py) over
its defaults, or over a --config FILE."""

from __future__ import annotations

import argparse
import json

from recorder import GloverecError, config, loading
from recorder.record.config import RecordConfig

RERECORD_FIELDS = ("repo_id", "root", "robot", "task", "fps", "retarget", "cameras", "wearer", "dart", "dart_time_s")


def add_parsers(sub, load_policy=None, check_policy=None) -> None:
    """``load_policy(path, env, task, robot, fps) -> agent``: what loads a --policy checkpoint, and
    ``check_policy(path)`` what says at once that a folder holds none (policies/ is a layer above this one)."""
    r = sub.add_parser("record", help="record demonstrations from a glove into a LeRobot dataset")
    r.add_argument("--config", help="a record YAML file (keys: the flags' names with _); flags override it")
    config.add_arguments(r, RecordConfig)
    r.add_argument("--json", action="store_true", help="print a JSON summary at the end")
    r.set_defaults(func=run_record, load_policy=load_policy, check_policy=check_policy)


def run_record(args: argparse.Namespace) -> int:
    from recorder.hand.profile import wearer_profile  # numpy and the hand model: not at start-up
    from recorder.record.store import check_root  # no LeRobot: the store loads it when it opens

    cfg = RecordConfig.load(args.config, **config.overrides(args, RecordConfig))
    # everything that needs no heavy import first: one line in a fraction of a second, before lerobot and torch
    cfg.check()  # names, values and the wrist's files
    cfg.glove_config.check_present()  # a port not plugged in, a missing log
    if cfg.policy is not None and args.check_policy is not None:
        args.check_policy(cfg.policy)  # a folder without a checkpoint
    check_root(cfg.root_path, cfg.resume)  # the dataset folder: there already, not ours, damaged
    profile = wearer_profile(cfg.wearer)  # a missing or impossible profile

    loading("LeRobot and MuJoCo")
    from recorder.record.recorder import record  # loads lerobot, torch and mujoco: not at start-up

    load = args.load_policy
    agent = (lambda env: load(cfg.policy, env, cfg.task, cfg.robot, cfg.fps)) if cfg.policy is not None else None
    summary = record(cfg, profile, agent)
    if args.json:
        print(json.dumps(summary))
    elif summary["interrupted"]:  # Ctrl-C: what was kept and how to go on; the exit status stays 130
        print(
            f"stopped: {summary['episodes_saved']} episode(s) saved in this session; {summary['root']} holds "
            f"{summary['total_episodes']} episodes, {summary['total_frames']} frames; the same command with "
            "--resume records more"
        )
    else:
        print(
            f"{summary['episodes_saved']} episode(s) saved; {summary['root']} now holds "
            f"{summary['total_episodes']} episodes, {summary['total_frames']} frames "
            f"(LeRobotDataset({summary['repo_id']!r}, root={summary['root']!r}))"
        )
    return 130 if summary["interrupted"] else 0


def add_rerecord_parser(sub) -> None:
    r = sub.add_parser("rerecord", help="rebuild a dataset from a session's MCAP log with other settings")
    r.add_argument("--log", dest="log_file", required=True, help="a session log (<root>/logs/session-*.mcap)")
    # the session's robot, task and fps unless given
    config.add_arguments(r, RecordConfig, include=RERECORD_FIELDS, required=("repo_id",))
    r.add_argument("--json", action="store_true")
    r.set_defaults(func=run_rerecord)


def run_rerecord(args: argparse.Namespace) -> int:
    from recorder.hand.profile import profile_from_dict
    from recorder.log.playback import read_log  # with the recorder: not at start-up
    from recorder.log.writer import WRIST_TOPIC

    info = read_log(args.log_file)  # a missing, foreign or damaged file: one-line GloverecError
    session = info.metadata.get("gloverec.session", {})
    plan = [
        (m["fields"]["seed"], m["fields"]["device_start_s"], m["fields"]["frames"])
        for m in info.marks
        if m["name"] == "episode_end" and m["fields"].get("device_start_s") is not None
    ]
    if not plan:
        raise GloverecError(f"{args.log_file} holds no re-recordable episodes (no episode marks with device times)")
    if any(p[1] < 0 for p in plan):
        raise GloverecError(
            f"{args.log_file} comes from a glove without a device clock: its episodes cannot be re-timed"
        )
    as_logged = {"robot": session.get("robot"), "task": session.get("task"), "fps": int(session.get("fps", 30))}
    for key in ("dart", "dart_time_s"):  # a DART session's noise: the same episode seeds draw the same noise
        if key in session:
            as_logged[key] = float(session[key])
    if WRIST_TOPIC in info.channels:  # recorded with a tracker: its poses, as the fusion took them, from the log
        as_logged["wrist"] = f"mcap:{args.log_file}"
    given = config.overrides(args, RecordConfig)
    cfg = RecordConfig.load(
        **{**as_logged, **given},
        glove=f"mcap:{args.log_file}",
        realtime=False,
        episodes=len(plan),
        log=False,
        view="none",
    )
    logged = session.get("hand_profile")  # the wearer's hand as recorded, unless --wearer names another
    profile = None
    if logged and cfg.wearer is None:
        try:
            profile = profile_from_dict(json.loads(logged), f"{args.log_file}: hand_profile")
        except json.JSONDecodeError:
            raise GloverecError(f"{args.log_file}: its hand_profile is not JSON") from None
    loading("LeRobot and MuJoCo")
    from recorder.record.recorder import Recorder  # lerobot, torch and mujoco: after the log's checks

    summary = Recorder(cfg, plan=plan, profile=profile).run()
    summary["source_log"] = args.log_file
    saved = f"re-recorded {summary['episodes_saved']} of {len(plan)} episode(s) from {args.log_file}"
    print(json.dumps(summary) if args.json else f"{saved} into {summary['root']}")
    return 0
