"""The `gloverec` command. Each subcommand parses its flags here and hands over to the module doing the job.

Bad input (a missing port, a wrong flag value, a file that is not ours) ends in one line on stderr and a
non-zero exit: GloverecError -> exit 1, argparse errors -> exit 2, Ctrl-C -> exit 130.
"""

from __future__ import annotations

import argparse
import json
import signal
import sys

from policies import cli as policies_cli
from recorder import GloverecError, __version__, config
from recorder.argtypes import positive_float
from recorder.calibrate import board as board_cli, cli as calibrate_cli, doctor_cli
from recorder.glove.config import GloveConfig, LinkConfig
from recorder.hub import cli as hub_cli
from recorder.record import cli as record_cli, inspect as inspect_cli
from recorder.review import cli as review_cli
from recorder.view import cli as view_cli
from recorder.wrist import open_wrist

EMULATOR_FIELDS = ("rate_hz", "mode", "motion", "seed")  # `gloverec emulate`'s flags: the glove's emulator fields


def _hostport(text: str) -> tuple[str, int]:
    host, _, port = text.rpartition(":")
    if not host or not port.isdigit() or not 0 < int(port) < 65536:
        raise argparse.ArgumentTypeError(f"expected HOST:PORT, got {text!r}")
    return host, int(port)


class _Parser(argparse.ArgumentParser):
    def error(self, message: str):  # one line, not argparse's usage block
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def build_parser() -> argparse.ArgumentParser:
    p = _Parser(prog="gloverec", description=__doc__.splitlines()[0])
    p.add_argument("--version", action="version", version=f"gloverec {__version__}")
    sub = p.add_subparsers(dest="command", required=True, metavar="COMMAND", parser_class=_Parser)

    e = sub.add_parser("emulate", help="serve a synthetic glove on a pseudo-terminal")
    config.add_arguments(e, GloveConfig, include=EMULATOR_FIELDS)
    e.add_argument("--duration", type=positive_float, help="seconds to stream (default: until killed)")
    e.add_argument("--link", help="also expose the port as this stable symlink (as udev does for real gloves)")
    e.add_argument(
        "--firmware",
        action="store_true",
        help="run the compiled glove core (firmware/) on the "
        "synthetic IMUs: the bytes are exactly what the real glove's code sends (builds it with cmake)",
    )
    e.add_argument(
        "--truth",
        metavar="FILE.npz",
        help="on exit, save the ground truth of every frame sent "
        "(seq, t_us, joint angles, parent-relative quaternions, fingertips, palm pose)",
    )
    e.add_argument(
        "--fault",
        action="append",
        default=[],
        metavar="FAULT",
        help="a build error in its raw frames, repeatable: swap:A,B (two IMUs' cables swapped), rotate:I:90|180|270 "
        "(IMU I glued turned about its normal), dead:I, stuck:I, flaky:I (drops out), rate:HZ (frames slower than "
        "announced) (docs/recording.md, 'Bringing up a new glove')",
    )
    e.set_defaults(func=cmd_emulate)

    m = sub.add_parser("monitor", help="live rate, errors and latency of a glove")
    config.add_arguments(m, LinkConfig, required=("glove",))
    m.add_argument("--json", action="store_true", help="print one JSON object at the end")
    m.set_defaults(func=cmd_monitor)

    w = sub.add_parser("wrist", help="the tracked wrist pose, rate, latency and tracking, to check a tracker")
    # --wrist and --wrist-camera as record, view and calibrate name them; --source and --camera: their old names
    config.add_option(w, "--wrist", "--source", required=True, metavar="SOURCE", help="the wrist source: udp:PORT or "
                      "udp:HOST:PORT (a tracker's pose stream; format: docs/wrist.md), marker:CAMERA (a device index, "
                      "video file or URL), or mcap:FILE (a session log's tracker poses, as `gloverec record --wrist` "
                      "logged them)")  # fmt: skip
    config.add_option(w, "--wrist-camera", "--camera", metavar="FILE.json", help="the marker camera's calibration, "
                      "for marker:CAMERA (default: the one `gloverec calibrate --camera CAMERA` saved)")  # fmt: skip
    w.add_argument("--marker-mm", type=positive_float, default=40.0, help="the marker's side, mm (default 40)")
    w.add_argument("--duration", type=positive_float, help="seconds (default: until Ctrl-C)")
    w.add_argument("--json", action="store_true", help="print one JSON object at the end")
    w.add_argument("--fast", action="store_true", help="play an mcap:FILE or a video file as fast as it reads (the "
                   "rate is then the recorded one, and there is no latency)")  # fmt: skip
    w.set_defaults(func=cmd_wrist)

    lg = sub.add_parser("log", help="record a glove session to an MCAP file")
    config.add_arguments(lg, LinkConfig, include=("glove", "duration"), required=("glove",))
    lg.add_argument("--out", required=True, help="output .mcap file")
    lg.add_argument("--json", action="store_true", help="print the link statistics as JSON at the end")
    lg.set_defaults(func=cmd_log)

    b = sub.add_parser("bridge", help="forward a serial glove's frames to UDP, one frame per datagram")
    config.add_arguments(b, LinkConfig, include=("glove", "duration"), required=("glove",))
    b.add_argument("--udp", required=True, type=_hostport, metavar="HOST:PORT")
    b.set_defaults(func=cmd_bridge)

    calibrate_cli.add_parser(sub)
    doctor_cli.add_parser(sub)
    board_cli.add_parser(sub)
    view_cli.add_parser(sub)
    record_cli.add_parsers(sub, load_policy=_load_policy, check_policy=_check_policy)
    record_cli.add_rerecord_parser(sub)
    inspect_cli.add_parsers(sub)
    review_cli.add_edit_parser(sub)
    review_cli.add_repair_parser(sub)
    review_cli.add_parser(sub)
    hub_cli.add_parsers(sub)
    policies_cli.add_parsers(sub)
    return p


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    # A process inherits its parent's ignored signals and its parent thread's blocked ones across exec, and
    # Python keeps an ignored SIGINT ignored: started by a program that ignored or blocked it (a test runner's
    # worker, a supervisor, a background job), Ctrl-C would never arrive and a recording would run to its end.
    # Unblocked and handled here, so Ctrl-C and `kill -INT` always stop a session.
    signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT, signal.SIGTERM})
    signal.signal(signal.SIGINT, signal.default_int_handler)
    signal.signal(signal.SIGTERM, _interrupt)  # `kill` ends a stream like Ctrl-C: files are closed cleanly
    try:
        return args.func(args) or 0
    except GloverecError as exc:
        print(f"gloverec: error: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        return 130
    except BrokenPipeError:
        return 0


def _interrupt(*_):
    raise KeyboardInterrupt


# ---------------------------------------------------------------- commands


def cmd_emulate(args) -> int:
    from recorder.emulator.checkup import CheckupMotion
    from recorder.emulator.emulator import Emulator  # numpy and the synthetic IMUs: not at start-up
    from recorder.emulator.faults import parse_fault
    from recorder.emulator.procedure import OnRequest

    faults = [parse_fault(f) for f in args.fault]  # a bad spelling: one line before the port exists
    glove = config.load(GloveConfig, overrides=config.overrides(args, GloveConfig))
    motion = glove.motion or "gestures"
    if motion == "demonstrations":
        raise GloverecError("--motion demonstrations is `gloverec record`'s emulated wearer (it performs the task "
                            "being recorded): pass gestures, random, calibration, calibration_pinch or "
                            "doctor")  # fmt: skip
    if motion.startswith("calibration"):  # performs the steps when `gloverec calibrate` switches it to raw
        motion = OnRequest("gestures", glove.seed, glove.rate_hz, pinch=motion == "calibration_pinch")
    elif motion == "doctor":  # performs the doctor's moves when `gloverec doctor` switches it to raw
        motion = OnRequest(procedure=CheckupMotion(glove.seed, glove.rate_hz), rate_hz=glove.rate_hz)
    emu = Emulator(
        glove.rate_hz,
        glove.mode,
        motion,
        glove.seed,
        link=args.link,
        keep_truth=bool(args.truth),
        firmware=args.firmware,
        faults=faults,
    )
    try:
        port = emu.plug()
    except OSError as exc:
        raise GloverecError(f"cannot create the emulator's port: {exc}") from None
    print(f"port: {port}", flush=True)
    # kill -USR1 unplugs the emulated USB cable, kill -USR2 plugs it back in (tests, manual checks)
    signal.signal(signal.SIGUSR1, lambda *_: emu.request("unplug"))
    signal.signal(signal.SIGUSR2, lambda *_: emu.request("replug"))
    try:
        emu.run(args.duration)
    finally:
        emu.close()
        if args.truth:
            print(f"ground truth of {emu.save_truth(args.truth)} frames in {args.truth}", file=sys.stderr)
        print(
            f"sent {emu.sent_frames} frames, dropped {emu.dropped_frames} behind a slow reader, "
            f"{emu.unread_frames} with no reader",
            file=sys.stderr,
        )
    return 0


def _finish(monitor, args, duration: float | None, what: str) -> int:
    report = monitor.report()
    if args.json:
        print(json.dumps(report), flush=True)
    if monitor.samples == 0 and (duration is not None or monitor.source.finished):
        raise GloverecError(
            f"no glove frames from {monitor.source.name} in {report['duration_s']:.1f} s "
            f"({report['bytes']} bytes, {report['errors']} rejected): is it a glove?"
        )
    if not args.json:
        lat = (
            "-"
            if report["latency_ms_p50"] is None
            else f"p50 {report['latency_ms_p50']:.2f} ms, p99 {report['latency_ms_p99']:.2f} ms"
        )
        print(
            f"{what}: {report['samples']} samples at {report['rate_hz']:.1f} Hz ({report['protocol']}), "
            f"{report['errors']} errors, {report['gaps']} gaps, {report['queue_drops']} queue drops, "
            f"{report['reconnects']} reconnects; latency {lat} ({report['clock']} clock)"
        )
    return 0


def cmd_monitor(args) -> int:
    from recorder.monitor import LinkMonitor  # numpy and the link: not at start-up

    link = _link(args)
    with _glove(link) as glove:
        monitor = LinkMonitor(glove.source)
        try:
            monitor.run(link.duration, live=not args.json and sys.stderr.isatty())
        except KeyboardInterrupt:
            pass
    return _finish(monitor, args, link.duration, "link")


def _load_policy(path, env, task: str, robot: str, fps: float):
    """`gloverec record --policy`: the checkpoint, checked against the recording's environment."""
    from policies.evaluate import load_for_recording  # torch and lerobot: not at start-up

    return load_for_recording(path, env, task, robot, fps)


def _check_policy(path) -> None:
    """`gloverec record --policy`: a folder that holds no checkpoint, said before torch and lerobot load."""
    from policies.checkpoint import find_pretrained  # pathlib only

    find_pretrained(path)


def cmd_wrist(args) -> int:
    from recorder.wrist.monitor import WristMonitor  # numpy: not at start-up

    source = open_wrist(args.wrist, args.wrist_camera, args.marker_mm, paced=not args.fast)
    with source:
        monitor = WristMonitor(source)
        try:
            monitor.run(args.duration, live=not args.json and sys.stderr.isatty())
        except KeyboardInterrupt:
            pass
    report = monitor.report()
    if args.json:
        print(json.dumps(report), flush=True)
    if monitor.poses == 0:
        why = f": {report['last_rejection']}" if report["last_rejection"] else ""
        raise GloverecError(f"no wrist poses from {source.name} in {report['duration_s']:.1f} s "
                            f"({report['rejected']} datagrams rejected{why})")  # fmt: skip
    if not args.json:
        print(monitor.status_line() + f"; {report['poses']} poses, {report['lost']} lost, {report['rejected']} "
              "rejected")  # fmt: skip
    return 0


def _link(args) -> LinkConfig:
    return config.load(LinkConfig, overrides=config.overrides(args, LinkConfig))


def _glove(link: LinkConfig):
    """The glove --glove names (the emulator too), with --protocol and --baud; logs play back in real time
    unless --fast. Its frames are what these commands take: no fusion."""
    from recorder.glove.glove import make_glove  # fusion and the emulator: not at start-up

    return make_glove(link.glove, fast=link.fast, warm_fusion=False)


def cmd_log(args) -> int:
    from recorder.log.writer import McapLogger  # mcap, numpy and the link: not at start-up
    from recorder.monitor import LinkMonitor

    link = _link(args)
    glove = _glove(link)
    source = glove.source
    try:
        logger = McapLogger(args.out, {"source": str(glove.config)})
    except OSError as exc:
        raise GloverecError(f"cannot write {args.out}: {exc.strerror or exc}") from None
    source.taps.append(logger)
    try:
        with glove:
            monitor = LinkMonitor(source)
            try:
                monitor.run(link.duration, live=not args.json and sys.stderr.isatty())
            except KeyboardInterrupt:
                pass
        for frame in source.drain():  # the reader has stopped: count what it logged after the monitor stopped
            monitor.consume(frame)
    finally:
        logger.close()
    return _finish(monitor, args, link.duration, f"logged to {args.out}")


def cmd_bridge(args) -> int:
    from recorder.bridge import Bridge  # the link: not at start-up
    from recorder.monitor import LinkMonitor

    host, port = args.udp
    link = _link(args)
    glove = _glove(link)
    bridge = Bridge(glove.source, host, port)
    with glove:
        monitor = LinkMonitor(glove.source)
        try:
            monitor.run(link.duration, live=sys.stderr.isatty(), tick=bridge.forward_commands)
        except KeyboardInterrupt:
            pass
    print(f"bridged {bridge.datagrams} datagrams to udp:{host}:{port} ({bridge.send_errors} send errors)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
