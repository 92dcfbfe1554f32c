"""`gloverec record` end to end: emulated glove -> pty -> loop -> env -> a dataset lerobot loads."""

import json
import os
import shutil
import signal
import subprocess
import sys
import time

import numpy as np
import pyarrow.parquet as pq
import pytest
from lerobot.datasets.lerobot_dataset import LeRobotDataset

import envs
from conftest import cli, gloverec, wait_for
from recorder.record.sidecar import read_sidecar


def record_cmd(command, *args, timeout=240):
    r = gloverec(command, "--json", *args, timeout=timeout)
    assert r.returncode == 0, r.stderr
    return json.loads(r.stdout.strip().splitlines()[-1])


def record(*args, timeout=240):
    return record_cmd("record", *args, timeout=timeout)


@pytest.fixture(scope="module")
def pose_dataset(pose_recording):
    return pose_recording  # 4 episodes, seeds 0-3, recorded once per run (conftest)


def test_recorded_dataset_loads_with_declared_shapes_fps_and_timestamps(pose_dataset):
    root, summary = pose_dataset
    ds = LeRobotDataset("test/pose", root=root)
    env = envs.make("pose", "glovehand").unwrapped
    assert ds.num_episodes == 4 == summary["total_episodes"] and ds.fps == 30
    assert ds.meta.features["observation.state"]["shape"] == (len(env.state_names),)
    assert ds.meta.features["action"]["names"] == list(env.action_names)
    # the clocks as stored, float64 (LeRobotDataset[i] hands them out as float32 tensors)
    times = pq.read_table(root / "data", columns=["episode_index", "index", "time.host_s", "time.device_s"])
    times = {c: np.asarray(times[c].to_numpy()) for c in times.column_names}
    order = np.argsort(times["index"])
    times = {c: v[order] for c, v in times.items()}
    for e in range(3):
        lo, hi = ds.meta.episodes[e]["dataset_from_index"], ds.meta.episodes[e]["dataset_to_index"]
        ts = np.array([float(ds[i]["timestamp"]) for i in range(lo, hi)])
        assert np.allclose(ts, np.arange(hi - lo) / 30, atol=1e-6)
        host, dev = (times[c][times["episode_index"] == e] for c in ("time.host_s", "time.device_s"))
        assert np.all(np.diff(host) > 0) and np.allclose(np.diff(dev), 1 / 30, atol=1e-3)
    item = ds[0]
    assert item["observation.glove"].shape == (24,) and item["task"].startswith("make the ")


def test_action_moves_state_to_the_next_state(pose_dataset):
    """Replaying the stored actions from the same seed reproduces every next state: the stored action is
    exactly what the environment applied, and action[t] leads from state[t] to state[t+1]."""
    root, _ = pose_dataset
    ds = LeRobotDataset("test/pose", root=root)
    side = read_sidecar(root)
    env = envs.make("pose", "glovehand")
    for e in range(ds.num_episodes):
        lo, hi = ds.meta.episodes[e]["dataset_from_index"], ds.meta.episodes[e]["dataset_to_index"]
        obs, _ = env.reset(seed=side[e]["seed"])
        for i in range(lo, hi):
            assert np.allclose(obs["observation.state"], ds[i]["observation.state"].numpy(), atol=1e-5)
            obs, *_ = env.step(ds[i]["action"].numpy())


def test_sidecar_counts_and_log_ranges(pose_dataset):
    root, summary = pose_dataset
    side = read_sidecar(root)
    assert [s["seed"] for s in side] == [0, 1, 2, 3]
    for s in side:
        assert s["glove_dropped"] == 0 and s["glove_errors"] == 0 and s["frames"] > 10
        assert s["log"]["file"] == summary["log"]
    assert (root / summary["log"]).stat().st_size > 1000
    from recorder.log.playback import read_log

    marks = read_log(root / summary["log"]).marks
    assert [m["name"] for m in marks].count("episode_end") == 4


@pytest.mark.process
def test_sigkill_during_recording_keeps_saved_episodes_and_resume_continues(tmp_path):
    root = tmp_path / "ds"
    args = [
        sys.executable,
        "-m",
        "recorder.cli",
        "record",
        "--view",
        "none",
        "--episodes",
        "50",
        "--root",
        str(root),
        "--repo-id",
        "test/kill",
    ]
    saved = 0
    for delay in (0.2, 1.3):  # after the first saved episode (start-up time varies with the machine)
        proc = subprocess.Popen(
            args + (["--resume"] if saved or root.is_symlink() else []),
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        first = ""
        while "saved:" not in first:
            first = proc.stderr.readline()
            assert first, "the recorder exited before saving an episode"
        time.sleep(delay)
        proc.send_signal(signal.SIGKILL)
        _, err = proc.communicate()  # also waits for the writer process: it saves what it was handed, then exits
        saved = (first + err).count("saved:") + saved
        ds = LeRobotDataset("test/kill", root=root)
        assert ds.num_episodes >= saved >= 1
        ds[len(ds) - 1]
    summary = record("--episodes", "2", "--root", str(root), "--repo-id", "test/kill", "--resume")
    assert summary["total_episodes"] == LeRobotDataset("test/kill", root=root).num_episodes >= saved + 2
    assert [s["episode_index"] for s in read_sidecar(root)] == list(range(summary["total_episodes"]))


@pytest.mark.parametrize(
    "args, needle",
    [
        (["--robot", "r2d2"], "unknown robot"),
        (["--task", "juggle"], "unknown task"),
        (["--repo-id", "../evil"], "bad repo id"),
        (["--repo-id", "noslash"], "bad repo id"),
        (["--task", "grasp", "--episode-time-s", "1"], "--episode-time-s 1: the grasp task's script takes"),
    ],
)
def test_bad_input_is_one_line(tmp_path, args, needle):
    """Checked before anything is opened or forked: in this process."""
    r = cli("record", "--episodes", "1", "--root", str(tmp_path / "ds"), *args)
    assert r.returncode == 1, r.stderr
    assert r.stderr.strip().count("\n") == 0 and needle in r.stderr and "Traceback" not in r.stderr


@pytest.mark.process
def test_a_missing_port_is_one_line(tmp_path):
    """The glove opens after the writer process is forked: as a user runs it, in a child process."""
    r = gloverec("record", "--episodes", "1", "--root", str(tmp_path / "ds"), "--glove", "/dev/does-not-exist")
    assert r.returncode == 1 and r.stderr.strip().count("\n") == 0 and "no such port" in r.stderr, r.stderr
    assert list(tmp_path.iterdir()) == []  # no hidden .ds.gloverec/ left behind (issue 42)


def test_bad_flag_values_are_usage_errors(tmp_path):
    """A flag value out of its range is caught by the parser (exit 2, one line), as for every command."""
    r = cli("record", "--episodes", "1", "--root", str(tmp_path / "ds"), "--fps", "0")
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and "--fps: must be positive" in r.stderr


def test_existing_root_needs_resume(pose_dataset):
    root, _ = pose_dataset
    r = cli("record", "--episodes", "1", "--root", str(root), "--repo-id", "test/pose")
    assert r.returncode == 1 and "--resume" in r.stderr


class Session:
    """`gloverec record` from a serial glove in a child process, its stderr collected as it comes."""

    def __init__(self, port, root, *extra):
        import threading

        self.proc = subprocess.Popen(
            [
                sys.executable,
                "-m",
                "recorder.cli",
                "record",
                "--view",
                "none",
                "--glove",
                f"serial:{port}",
                "--root",
                str(root),
                "--repo-id",
                "test/live",
                "--json",
                *extra,
            ],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        self.lines = []
        self._t = threading.Thread(target=lambda: self.lines.extend(iter(self.proc.stderr.readline, "")), daemon=True)
        self._t.start()

    def wait_for(self, text, timeout=60):
        from conftest import wait_for

        assert wait_for(lambda: any(text in ln for ln in self.lines), timeout), self.lines

    def key(self, line):
        self.proc.stdin.write(line + "\n")
        self.proc.stdin.flush()

    def finish(self):
        # stdout only: communicate() would also read stderr, taking lines from under the reader thread
        out = self.proc.stdout.read()
        self.proc.wait(timeout=90)
        self._t.join(5)
        assert self.proc.returncode == 0, "".join(self.lines)
        return json.loads(out.strip().splitlines()[-1]), "".join(self.lines)


def test_keyboard_lines_end_rerecord_and_stop(emulator, tmp_path):
    episode_s = 9.0
    emu = emulator("--rate", "200")
    rec = Session(
        emu.port,
        tmp_path / "ds",
        "--episodes",
        "5",
        "--episode-time-s",
        str(episode_s),
        "--reset-time-s",
        "0.2",
        "--task",
        "grasp",
    )  # grasp episodes never end early on success: the keys decide (long ones: a loaded machine may be slow to press)
    rec.wait_for("episode 0 started")
    time.sleep(0.5)
    rec.key("rerecord")
    rec.wait_for("re-recording it")
    rec.wait_for("episode 0 started: ", timeout=30)
    assert wait_for(lambda: sum("episode 0 started" in ln for ln in rec.lines) == 2, 30)
    time.sleep(0.8)
    rec.key("next")  # ends the re-recorded episode 0 early
    rec.wait_for("episode 1 started")  # not for "episode 0 saved": the writer process may say so seconds later,
    time.sleep(0.8)  # on a loaded machine after episode 1 has ended by its time
    rec.key("stop")  # saves episode 1 so far and ends the session
    summary, err = rec.finish()
    assert summary["episodes_saved"] == 2 and summary["rerecorded"] == 1, (summary, err)
    assert "episode 0 saved" in err and "episode 1 saved" in err, err
    side = read_sidecar(tmp_path / "ds")
    assert all(5 < s["frames"] < (episode_s - 1) * 30 for s in side), [s["frames"] for s in side]  # ended by keys
    assert side[0]["realtime"] and side[0]["jitter_ms_p99"] is not None


def test_unplug_discards_the_episode_and_recording_carries_on(emulator, tmp_path):
    emu = emulator("--rate", "200")
    rec = Session(
        emu.port,
        tmp_path / "ds",
        "--episodes",
        "2",
        "--episode-time-s",
        "4.6",
        "--reset-time-s",
        "0.2",
        "--task",
        "grasp",
    )
    rec.wait_for("episode 0 started")
    time.sleep(0.5)
    emu.unplug()
    time.sleep(1.0)
    emu.replug()
    summary, err = rec.finish()
    assert summary["lost"] == 1 and summary["episodes_saved"] == 2, err
    assert "the glove went away" in err
    ds = LeRobotDataset("test/live", root=tmp_path / "ds")
    assert ds.num_episodes == 2


@pytest.mark.process
def test_rerecord_rebuilds_the_dataset_from_its_log(pose_dataset, tmp_path):
    root, summary = pose_dataset
    log = root / summary["log"]
    same = record_cmd("rerecord", "--log", str(log), "--repo-id", "test/again", "--root", str(tmp_path / "same"))
    assert same["total_episodes"] == 4
    a, b = LeRobotDataset("test/pose", root=root), LeRobotDataset("test/again", root=tmp_path / "same")
    assert len(a) == len(b)
    for i in range(0, len(a), 7):  # the same glove bytes, the same seeds: the same demonstrations
        assert np.allclose(a[i]["observation.glove"], b[i]["observation.glove"], atol=1e-4)
        assert np.allclose(a[i]["action"], b[i]["action"], atol=1e-4)
    other = record_cmd(
        "rerecord",
        "--log",
        str(log),
        "--repo-id",
        "test/shadow",
        "--root",
        str(tmp_path / "shadow"),
        "--robot",
        "shadow",
    )
    ds = LeRobotDataset("test/shadow", root=tmp_path / "shadow")
    assert other["total_episodes"] == 4 and ds.meta.robot_type == "shadow" and len(ds) == len(a)
    r = gloverec("rerecord", "--log", str(tmp_path / "nope.mcap"), "--repo-id", "test/x")
    assert r.returncode == 1 and r.stderr.count("\n") == 1


def test_inspect_reports_episodes_and_plots(pose_dataset, tmp_path):
    root, _ = pose_dataset
    png = tmp_path / "plot.png"
    r = cli("inspect", "--repo-id", "test/pose", "--root", str(root), "--episode", "1", "--plot", str(png), "--json")
    assert r.returncode == 0, r.stderr
    rep = json.loads(r.stdout)
    assert [e["episode"] for e in rep["episodes"]] == [0, 1, 2, 3]
    assert all(e["frames"] > 10 and e["glove_dropped"] == 0 for e in rep["episodes"])
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 20_000
    r = cli("inspect", "--repo-id", "test/pose", "--root", str(root), "--episode", "9", "--plot", str(png))
    assert r.returncode == 1 and "no episode 9" in r.stderr
    # an episode whose physics blew up (the recorder's sidecar says when) is flagged in the table
    blown = tmp_path / "blown"
    shutil.copytree(root, blown)
    sidecar = blown / "meta" / "gloverec" / "episodes.jsonl"
    lines = [json.loads(x) for x in sidecar.read_text().splitlines() if x.strip()]
    lines[2]["physics_unstable_s"] = 4.8
    lines[3]["takeover"] = {"policy": "P", "frames_by_wearer": 52, "switches": [], "interventions": 1}
    sidecar.write_text("".join(json.dumps(x) + "\n" for x in lines))
    before = sorted(p.name for p in tmp_path.iterdir())
    r = cli("inspect", "--repo-id", "test/pose", "--root", str(blown))  # no --plot: nothing written beside it
    assert sorted(p.name for p in tmp_path.iterdir()) == before and "plot of episode" not in r.stdout
    flagged = [x for x in r.stdout.splitlines() if "physics blew up at 4.8 s" in x]
    assert r.returncode == 0 and len(flagged) == 1 and flagged[0].split()[0] == "2", r.stdout
    took_over = [x for x in r.stdout.splitlines() if "[the wearer drove 52 frames]" in x]  # and a takeover's share
    assert len(took_over) == 1 and took_over[0].split()[0] == "3", r.stdout
    broken = tmp_path / "broken"
    broken.mkdir()
    (broken / "meta").mkdir()
    (broken / "meta" / "info.json").write_text("{not json")
    r = cli("inspect", "--repo-id", "test/pose", "--root", str(broken))
    assert r.returncode == 1 and r.stderr.count("\n") == 1 and "Traceback" not in r.stderr


def test_a_raw_glove_in_real_time_starts_its_first_episode_once_fusion_has_a_pose(emulator, tmp_path):
    """Host fusion shows its first pose after ~1 s of rest; a reset period shorter than that must not start an
    episode without a pose (which would count as a lost glove and record the episode again)."""
    emu = emulator("--rate", "200", "--output", "raw")
    env = {**os.environ, "GLOVEREC_CALIBRATION_DIR": str(tmp_path / "cal")}  # none saved: uncalibrated
    r = gloverec(
        "record",
        "--glove",
        f"serial:{emu.port}",
        "--episodes",
        "1",
        "--episode-time-s",
        "1",
        "--reset-time-s",
        "0.1",
        "--root",
        str(tmp_path / "ds"),
        "--repo-id",
        "test/raw",
        "--json",
        timeout=120,
        env=env,
    )
    assert r.returncode == 0, r.stderr
    summary = json.loads(r.stdout.strip().splitlines()[-1])
    assert summary["episodes_saved"] == 1 and summary["lost"] == 0, r.stderr
    assert LeRobotDataset("test/raw", root=tmp_path / "ds").num_frames == 30


def test_real_time_episodes_run_without_cyclic_gc_and_restore_it():
    import gc

    from recorder.record.clock import clock_for

    realtime, fast = (clock_for(f, glove=None, fps=30, nominal_rate_hz=200.0) for f in (False, True))
    assert gc.isenabled() and realtime.realtime and not fast.realtime
    with realtime.episode():
        assert not gc.isenabled()
    assert gc.isenabled()
    with pytest.raises(RuntimeError), realtime.episode():
        raise RuntimeError("an episode that fails")
    assert gc.isenabled()
    with fast.episode():  # faster than real time: collections as usual
        assert gc.isenabled()


# ---------------------------------------------------------------- a session as a person runs it (issue 20)

PREPARED = """
import json, sys
from recorder.fusion import get_filter
from recorder.fusion.dispatch import loops
from recorder.glove.glove import open_glove
said = []
pipeline = loops(get_filter("inertial"))  # the host pipeline of the default filter, not compiled yet
emulated = open_glove("emulator", say=said.append)  # pose frames: nothing to compile
pose = len(pipeline.run.signatures)
emulated.close()
glove = open_glove(sys.argv[1], say=said.append)  # a serial glove may send raw frames
print(json.dumps({"pose": pose, "serial": len(pipeline.run.signatures), "read": glove.received, "said": said}))
glove.close()
"""


@pytest.mark.process
def test_a_glove_that_may_send_raw_frames_has_host_fusion_compiled_when_it_opens(emulator, tmp_path):
    """What froze a reset period for 10-40 s and then ended it with a false "no glove frames": host fusion's
    numba kernels were compiled at the first raw frame, inside the loop (9 s on an idle 2-core machine the first
    time after an install, 25 s under load), so the view and the countdown stopped and the loop's wall-clock
    check fired as soon as it ran again. The kernels are now compiled (or loaded from numba's cache) when the
    glove opens, before any frame is read. A fresh interpreter, so nothing compiled them before."""
    emu = emulator("--rate", "200", "--output", "raw")
    r = subprocess.run([sys.executable, "-c", PREPARED, emu.port], capture_output=True, text=True, timeout=180)
    assert r.returncode == 0, r.stderr
    out = json.loads(r.stdout)
    assert out["pose"] == 0 and out["serial"] >= 1 and out["read"] == 0, out


def test_a_slow_kernel_compile_is_said_while_it_runs(monkeypatch):
    """Once per install the compile takes 10-30 s: the person is told, while it runs and when it is done."""
    from recorder.fusion import session

    monkeypatch.setattr(session, "COMPILE_NOTE_S", 0.05)
    monkeypatch.setattr(session, "compile_kernels", lambda config: time.sleep(0.3) or 0.3)
    said = []
    session.SessionFusion().warm_up(said.append)
    assert said[0].startswith("preparing host fusion: compiling its kernels") and "host fusion ready" in said[1]
    monkeypatch.setattr(session, "compile_kernels", lambda config: 0.0)  # cached: nothing to say
    said.clear()
    session.SessionFusion().warm_up(said.append)
    assert said == []


def test_a_glove_without_hand_frames_ends_the_session_saying_why(tmp_path):
    """A log of status frames only, as a glove that never streams its hand: one line that says what came and
    what the first pose waited for (it used to say "no glove frames" whatever came)."""
    from recorder.log.writer import McapLogger
    from recorder.protocol import encode_frame
    from recorder.protocol.frames import StatusFrame

    log = tmp_path / "status.mcap"
    with McapLogger(str(log), {"source": "test"}) as logger:
        for k in range(20):
            logger(encode_frame(StatusFrame(k, k * 100_000, glove_id=7)), 1_000_000_000 + k * 100_000_000, [])
    r = cli("record", "--glove", f"mcap:{log}", "--episodes", "1", "--root", str(tmp_path / "ds"), "--view", "none")
    last = r.stderr.strip().splitlines()[-1]
    assert r.returncode == 1 and "Traceback" not in r.stderr, r.stderr
    assert last.startswith("gloverec: error: mcap:") and last.endswith("ended after 20 frames without a hand pose")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["status.mcap"]  # nothing saved: no .ds.gloverec/ left


@pytest.mark.process
def test_ctrl_c_keeps_the_saved_episodes_and_says_so(tmp_path):
    """Started with SIGINT ignored and blocked, as a child inherits them from a parent that ignores or blocks it
    (a test runner's worker, a supervisor: it happened in this suite), Ctrl-C still stops the session."""
    root = tmp_path / "ds"
    proc = subprocess.Popen(
        [sys.executable, "-m", "recorder.cli", "record", "--view", "none", "--episodes", "50", "--root", str(root),
         "--repo-id", "test/int"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        preexec_fn=lambda: (signal.signal(signal.SIGINT, signal.SIG_IGN),
                            signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})),
    )  # fmt: skip
    lines = []
    for line in proc.stderr:
        lines.append(line)
        if line.startswith("episode 1 saved"):
            break
    proc.send_signal(signal.SIGINT)
    out, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, "".join(lines) + err
    last = out.strip().splitlines()[-1]
    saved = int(last.split("stopped: ")[1].split(" ")[0])
    assert saved >= 2 and "--resume" in last and "Traceback" not in err
    assert LeRobotDataset("test/int", root=root).meta.total_episodes == saved


CHECK_FIRST = """
import json, sys
from recorder.cli import main
code = main(sys.argv[1:])
print(json.dumps({"code": code, "heavy": sorted(m for m in ("torch", "lerobot") if m in sys.modules)}))
"""


@pytest.mark.process
@pytest.mark.parametrize(
    "args, needle",
    [
        (["record", "--robot", "shadw"], "--robot shadw: unknown robot; valid: glovehand, leap, shadow"),
        (["record", "--task", "grasp", "--episode-time-s", "3"], "--episode-time-s 3: the grasp task's script"),
        (["eval", "--policy", "demonstrator", "--robot", "shadw", "--task", "pose"], "--robot shadw: unknown"),
        (["eval", "--policy", "demonstrator", "--robot", "shadow", "--task", "graps"], "--task graps: unknown"),
    ],
)
def test_wrong_names_and_values_fail_before_torch_and_lerobot_load(args, needle):
    r = subprocess.run([sys.executable, "-c", CHECK_FIRST, *args], capture_output=True, text=True, timeout=60)
    out = json.loads(r.stdout.strip().splitlines()[-1]) if r.stdout.strip() else {}
    assert needle in r.stderr and r.stderr.count("\n") == 1, r.stderr
    assert out == {"code": None, "heavy": []} or out.get("heavy") == [], out


@pytest.fixture(scope="module")
def damaged(pose_dataset, tmp_path_factory):
    """A copy of the recording (its snapshots too) with one data file cut short, and the intact one in a hub
    whose copy of that file is cut short as well."""
    import shutil

    root, _ = pose_dataset
    base = tmp_path_factory.mktemp("damaged")
    hub = base / "hub"
    assert cli("push", "--repo-id", "test/pose", "--root", str(root), "--hub", str(hub)).returncode == 0
    shutil.copytree(root.parent / f".{root.name}.gloverec", base / f".{root.name}.gloverec", symlinks=True)
    copy = base / root.name
    os.symlink(os.readlink(root), copy)  # the recording's root: a link to its newest snapshot
    victim = sorted((copy / "data").rglob("*.parquet"))[-1]
    os.truncate(victim, victim.stat().st_size // 2)
    published = sorted((hub / "test").glob("pose@v*/data/**/*.parquet"))[-1]
    published.chmod(0o644)
    os.truncate(published, published.stat().st_size // 2)
    return copy, hub


@pytest.mark.parametrize(
    "args",
    [
        ("inspect", "--plot", "PLOT"),
        ("inspect", "--no-plot"),
        ("train", "--steps", "2", "--out", "OUT"),
        ("replay", "--episode", "0"),
    ],
)
def test_a_damaged_dataset_is_one_line(damaged, tmp_path, args):
    copy, _ = damaged
    args = [a.replace("PLOT", str(tmp_path / "p.png")).replace("OUT", str(tmp_path / "out")) for a in args]
    r = cli(args[0], "--repo-id", "test/pose", "--root", str(copy), *args[1:])
    assert r.returncode == 1 and r.stderr.count("\n") == 1, r.stderr
    assert "is a damaged LeRobot dataset: data/" in r.stderr and "is not a readable parquet file" in r.stderr


def test_a_damaged_hub_version_is_refused_before_training(damaged, tmp_path):
    _, hub = damaged
    r = cli("train", "--repo-id", "test/pose", "--hub", str(hub), "--steps", "2", "--out", str(tmp_path / "out"))
    assert r.returncode == 1 and r.stderr.count("\n") == 1, r.stderr
    assert "test/pose v1 in" in r.stderr and "is damaged (altered data/" in r.stderr
    assert not (tmp_path / "out").exists()


@pytest.mark.process
def test_resuming_a_damaged_recording_is_one_line(damaged):
    copy, _ = damaged
    r = gloverec("record", "--episodes", "1", "--root", str(copy), "--repo-id", "test/pose", "--resume")
    assert r.returncode == 1 and r.stderr.count("\n") == 1, r.stderr
    assert "is a damaged LeRobot dataset" in r.stderr


def test_lines_that_arrive_together_each_act_at_once():
    """Two lines in one read of a pipe ("next\\nstop\\n", as a script writes them) are both taken: the second
    does not wait for more input (stdin's readline buffered it out of select's sight)."""
    from recorder.record.control import NEXT, RERECORD, STOP, Control

    r, w = os.pipe()
    control = Control(stdin=os.fdopen(r))
    try:
        os.write(w, b"next\nstop\nre")
        assert wait_for(lambda: len(control._pending) == 2, 5.0)
        os.write(w, b"record\n")
        assert wait_for(lambda: len(control._pending) == 3, 5.0)
        assert [control.take() for _ in range(4)] == [NEXT, STOP, RERECORD, None]
    finally:
        control.close()
        os.close(w)


@pytest.mark.process
def test_ctrl_c_on_a_terminal_starts_the_stopped_line_afresh(tmp_path):
    """On a terminal the recorder redraws a status line without a newline; Ctrl-C's "stopped: ..." must not be
    glued to it ("glove upstopped: ...")."""
    import pty

    controller, terminal = pty.openpty()
    proc = subprocess.Popen([sys.executable, "-m", "recorder.cli", "record", "--glove", "emulator", "--task", "pose",
                             "--episodes", "1", "--episode-time-s", "60", "--view", "none", "--no-log",
                             "--repo-id", "test/tty", "--root", str(tmp_path / "ds")],
                            stdin=terminal, stdout=terminal, stderr=terminal)  # fmt: skip
    os.close(terminal)
    seen = b""
    try:
        while b"latency p99" not in seen.rsplit(b"\n", 1)[-1]:  # the status line is drawn: the episode is under way
            chunk = os.read(controller, 4096)
            assert chunk, seen.decode(errors="replace")[-2000:]
            seen += chunk
        proc.send_signal(signal.SIGINT)
        while True:
            try:
                chunk = os.read(controller, 4096)
            except OSError:  # the terminal closed with the process
                break
            if not chunk:
                break
            seen += chunk
        assert proc.wait(timeout=120) == 130
    finally:
        proc.kill()
        os.close(controller)
    text = seen.decode(errors="replace")
    at = text.index("stopped: ")
    assert text[:at].endswith(("\n", "\x1b[K")), repr(text[at - 80 : at + 20])
