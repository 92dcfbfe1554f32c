"""The glove link on real pseudo-terminals: emulator process -> pty -> pyserial reader thread."""

import os
import signal
import socket
import time
import tty

import numpy as np
import pytest

from conftest import cli, gloverec, wait_for
from recorder import GloverecError
from recorder.link.clock import DeviceClock
from recorder.link.serial_source import SerialSource
from recorder.link.udp_source import UdpSource
from recorder.protocol import CommandCode, EventCode, EventFrame, Mode, PoseFrame, RawFrame, encode_command
from recorder.protocol.codec import encode_frame
from recorder.protocol.frames import identity_pose


def collect(source, n, timeout=5.0, kind=(PoseFrame, RawFrame)):
    frames, end = [], time.monotonic() + timeout
    while len(frames) < n and time.monotonic() < end:
        f = source.read(timeout=0.1)
        if isinstance(f, kind):
            frames.append(f)
    return frames


def test_emulated_glove_streams_pose_frames(emulator):
    emu = emulator("--rate", "200", "--output", "pose")
    with SerialSource(emu.port) as src:
        frames = collect(src, 200)
        stats = src.stats()
    assert len(frames) == 200
    q = np.stack([f.quats for f in frames])
    assert np.allclose(np.linalg.norm(q, axis=-1), 1, atol=1e-3)
    assert q.std(axis=0).max() > 0.01, "the hand is not moving"
    assert stats.protocol == "binary" and stats.decode["errors"] == 0 and stats.decode["gaps"] == 0
    rx = np.array([f.rx_ns for f in frames]) * 1e-9
    assert np.all(np.diff(rx) >= 0)  # stamped as read (the rate and latency: bench/link.py)
    assert src.clock.host_monotonic
    latency = [f.rx_ns * 1e-9 - src.host_time_s(f) for f in frames]
    assert 0 <= np.median(latency) < 0.05


def test_raw_mode_carries_twelve_mpu9250(emulator):
    emu = emulator("--rate", "200", "--output", "raw")
    with SerialSource(emu.port) as src:
        frames = collect(src, 50)
    assert len(frames) == 50 and all(f.data.shape == (12, 7) for f in frames)
    g = np.linalg.norm(np.stack([f.accel_g for f in frames]), axis=-1)
    assert 0.5 < np.median(g) < 1.5  # gravity dominates a moving hand's accelerometers
    assert np.all((20 < frames[-1].temperature_c) & (frames[-1].temperature_c < 40))


def test_legacy_json_glove_is_detected(emulator):
    emu = emulator("--rate", "60", "--output", "json")
    with SerialSource(emu.port) as src:
        frames = collect(src, 20)
        assert src.stats().protocol == "json"
    assert len(frames) == 20 and all(f.t_us == -1 for f in frames)


def test_commands_switch_the_glove_mode(emulator):
    emu = emulator("--rate", "200", "--output", "pose")
    with SerialSource(emu.port) as src:
        assert len(collect(src, 20)) == 20
        src.command(CommandCode.SET_MODE, Mode.RAW)
        assert wait_for(lambda: isinstance(src.read(0.1), RawFrame))
        src.command(CommandCode.SET_MODE, Mode.JSON)
        assert wait_for(lambda: src.stats().protocol == "json" and src.read(0.1) is not None)
        src.send(encode_command(CommandCode.SET_MODE, Mode.POSE))  # seq 0 again: the glove ignores seq
        assert wait_for(lambda: isinstance(src.read(0.1), PoseFrame), timeout=5)


def test_unplug_and_replug_reconnects(emulator):
    emu = emulator("--rate", "200")
    with SerialSource(emu.port) as src:
        assert len(collect(src, 20)) == 20
        emu.unplug()
        assert wait_for(lambda: not src.connected)
        assert not os.path.exists(emu.port)
        src.drain()
        time.sleep(0.3)
        emu.replug()
        assert wait_for(lambda: src.connected)
        after = collect(src, 50)
        stats = src.stats()
    assert len(after) == 50
    assert stats.reconnects == 1 and stats.disconnected_s > 0.2
    assert stats.decode["errors"] == 0


def test_garbage_between_frames_is_counted_and_skipped(tmp_path):
    master, slave = os.openpty()
    tty.setraw(slave)
    port = os.ttyname(slave)
    os.close(slave)
    rng = np.random.default_rng(1)
    with SerialSource(port) as src:
        sent = []
        for seq in range(60):
            f = PoseFrame(seq, seq * 1000, identity_pose())
            sent.append(f)
            junk = rng.integers(0, 256, rng.integers(0, 30), dtype=np.uint8).tobytes()
            os.write(master, junk + b"\x00" + encode_frame(f))
            time.sleep(0.002)
        got = collect(src, 60, timeout=3)
        stats = src.stats()
    os.close(master)
    assert [f.seq for f in got] == list(range(60))
    assert stats.decode["errors"] > 0 and stats.decode["gaps"] == 0


def test_a_slow_consumer_loses_the_oldest_frames_and_counts_them(emulator):
    emu = emulator("--rate", "500")
    src = SerialSource(emu.port, queue_size=16).open()
    try:
        time.sleep(1.0)
        stats = src.stats()
        frames = src.drain()
    finally:
        src.close()
    assert len(frames) == 16 and stats.queue_drops > 100
    assert frames[-1].seq - frames[0].seq == 15


def test_missing_port_is_a_clear_error(tmp_path):
    with pytest.raises(GloverecError, match="no such port"):
        SerialSource(str(tmp_path / "nope")).open()
    r = cli("monitor", "--glove", str(tmp_path / "nope"), "--duration", "1")
    assert r.returncode == 1 and r.stderr.count("\n") == 1 and "no such port" in r.stderr


def test_a_port_that_is_not_a_glove_fails_cleanly():
    master, slave = os.openpty()
    tty.setraw(slave)
    port = os.ttyname(slave)
    os.close(slave)
    import threading

    stop = threading.Event()

    def chatter():
        while not stop.is_set():
            try:
                os.write(master, b"AT+OK\r\nhello \x00 modem\r\n" + os.urandom(40))
            except OSError:
                pass
            time.sleep(0.01)

    t = threading.Thread(target=chatter, daemon=True)
    t.start()
    try:
        r = cli("monitor", "--glove", port, "--duration", "1.5", "--json")
    finally:
        stop.set()
        t.join()
        os.close(master)
    assert r.returncode == 1
    assert r.stderr.strip().count("\n") == 0 and "is it a glove?" in r.stderr
    assert '"frames": 0' in r.stdout


def test_monitor_json_report(emulator):
    emu = emulator("--rate", "250")
    r = gloverec("monitor", "--glove", emu.port, "--duration", "2", "--json")
    assert r.returncode == 0, r.stderr
    import json

    rep = json.loads(r.stdout)
    for key in ("frames", "rate_hz", "errors", "gaps", "latency_ms_p50", "latency_ms_p99", "protocol"):
        assert key in rep
    assert rep["protocol"] == "binary" and rep["errors"] == 0 and rep["gaps"] == 0
    # measured, whatever the load (the figures an idle machine gives are bench/link.py's)
    assert rep["frames"] > 10 and rep["rate_hz"] > 0 and 0 <= rep["latency_ms_p50"] <= rep["latency_ms_p99"]


def test_udp_source_counts_lost_and_reordered_datagrams():
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sock.bind(("127.0.0.1", 0))
    port = sock.getsockname()[1]
    sock.close()
    with UdpSource(port, "127.0.0.1") as src:
        out = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        order = [0, 1, 2, 4, 3, 5, 5, 8, 9]  # 3 late, 5 twice, 6 and 7 lost
        for seq in order:
            out.sendto(encode_frame(EventFrame(seq, 0, EventCode.BUTTON)), ("127.0.0.1", port))
        # a datagram torn in half must not be glued to the next one
        whole = encode_frame(EventFrame(10, 0, EventCode.BUTTON))
        out.sendto(whole[:5], ("127.0.0.1", port))
        out.sendto(whole[5:], ("127.0.0.1", port))
        out.sendto(encode_frame(EventFrame(11, 0, EventCode.BUTTON)), ("127.0.0.1", port))
        got = collect(src, 8, timeout=2, kind=EventFrame)
        stats = src.stats().decode
        out.close()
    assert [f.seq for f in got] == [0, 1, 2, 4, 5, 8, 9, 11]
    assert stats["reordered"] == 2 and stats["gaps"] == 1 + 2 + 1 and stats["errors"] == 2


def test_bridge_forwards_serial_frames_to_udp(emulator):
    import subprocess
    import sys

    emu = emulator("--rate", "200")
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sock.bind(("127.0.0.1", 0))
    port = sock.getsockname()[1]
    sock.close()
    with UdpSource(port, "127.0.0.1") as src:
        bridge = subprocess.Popen(
            [
                sys.executable,
                "-m",
                "recorder.cli",
                "bridge",
                "--glove",
                emu.port,
                "--udp",
                f"127.0.0.1:{port}",
            ],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )  # until stopped: the test says when it has seen enough, not a duration raced against start-up
        try:
            frames = collect(src, 200, timeout=120)  # a hang guard: the bridge's start-up is slow on a loaded machine
            src.send(encode_command(CommandCode.SET_MODE, 0))  # back through the bridge to the glove
            raw = wait_for(lambda: isinstance(src.read(0.1), RawFrame), timeout=30)
        finally:
            bridge.send_signal(signal.SIGINT)  # Ctrl-C: the bridge says what it forwarded and exits 0
            out, err = bridge.communicate(timeout=60)
        stats = src.stats().decode
    assert len(frames) == 200 and bridge.returncode == 0, err
    assert stats["errors"] == 0 and stats["gaps"] == 0
    assert raw, "a command sent over UDP did not reach the glove"
    assert "bridged" in out


def test_device_clock_estimates_offset_and_drift():
    rng = np.random.default_rng(0)
    clock = DeviceClock()
    offset, drift = 12.5, 40e-6  # device starts 12.5 s behind the host and runs 40 ppm slow
    t_dev = np.arange(0, 120, 0.005)
    host = t_dev * (1 + drift) + offset + 0.0002 + rng.exponential(0.001, t_dev.size)
    for d, h in zip(t_dev, host):
        t_us = int(d * 1e6) & 0xFFFFFFFF
        clock.update(clock.unwrap(t_us, int(h * 1e9)), int(h * 1e9))
    assert abs(clock.drift * 1e6 - 40) < 3
    assert abs(clock.to_host_s(100.0) - (100 * (1 + drift) + offset + 0.0002)) < 0.0005


def test_device_clock_unwraps_the_32bit_counter():
    clock = DeviceClock()
    t = [clock.unwrap(x, 0) for x in (0xFFFFFF00, 0xFFFFFFF0, 0x10, 0x200)]
    assert np.all(np.diff(t) > 0) and abs(t[2] - t[1] - 32e-6) < 1e-9


def test_an_older_time_read_after_a_wrap_is_no_second_wrap():
    """The glove unwraps its pose samples' times and its frames' apart, so a time from just before a wrap can come
    after the frames past it; it once counted as a wrap back and the next frame as another (8590 s ahead)."""
    clock = DeviceClock()
    t = [clock.unwrap(x, 0) for x in (0xFFFFFF00, 0x10, 0xFFFFFFF0, 0x20, 0x18)]
    np.testing.assert_allclose(np.array(t) - t[0], np.array([0, 0x110, 0xF0, 0x120, 0x118]) * 1e-6, atol=1e-9)


def test_firmware_in_the_loop_through_the_pty(emulator):
    """The compiled glove core is the emulator's firmware: its compact frames reach the reader intact."""
    from recorder.protocol import PoseCompactFrame

    emu = emulator("--firmware", "--output", "compact", "--rate", "200", "--motion", "random")
    with SerialSource(emu.port) as src:
        frames = collect(src, 300, timeout=10, kind=PoseCompactFrame)
        stats = src.stats()
    assert len(frames) == 300 and stats.decode["errors"] == 0 and stats.decode["gaps"] == 0
    angles = np.stack([f.angles for f in frames])
    assert np.isfinite(angles).all() and np.ptp(angles, axis=0).max() > 0.1  # after boot calibration it moves
    assert np.allclose(np.linalg.norm(np.stack([f.palm_quat for f in frames]), axis=1), 1, atol=1e-3)
    assert src.clock.host_monotonic


def test_the_glove_rate_is_counted_over_a_second_of_its_clock():
    """What the views show as the glove's rate. A median of the pose intervals read 10417 Hz for a glove whose
    frames came in bursts (an emulator catching up after being starved of CPU stamps each frame as it sends it)
    and 0 Hz while a raw glove rested before host fusion's first pose: a count over a window of glove time reads
    the 200 Hz the glove sends in both."""
    from recorder.glove.track import FrameRate, PoseTrack
    from recorder.hand.pose import HandPose

    bursts = [k * 0.05 + j * 1e-4 for k in range(60) for j in range(10)]  # 10 frames each 50 ms, 0.1 ms apart
    rate, track = FrameRate(1.0), PoseTrack()
    pose = HandPose(np.zeros(20), np.array([1.0, 0, 0, 0]), np.ones(20, bool))
    for t in bursts:
        rate.add(t)
        track.push(t, pose)
    assert 1 / track.interval_s(0.005) > 5000  # what the views showed
    assert rate.hz() == pytest.approx(200.0, rel=0.02)
    steady = FrameRate(1.0)
    assert steady.hz(default=-1.0) == -1.0
    for k in range(1000):
        steady.add(k / 200.0)
    assert steady.hz() == pytest.approx(200.0)
    steady.add(10.0)  # after a gap of 5 s: only what the last second holds
    assert steady.hz() == 1.0


def test_a_fast_write_waiting_for_the_reader_does_not_block_scheduling_a_button():
    """Faster than real time the emulator waits for room in the port while holding it (no frame dropped); a
    recording loop that schedules the demonstrator's button meanwhile must not wait for that reader, which may be
    waiting for the loop itself (seen: a 100-episode camera recording hung after 21 episodes)."""
    import threading

    from recorder.emulator.emulator import Emulator

    emu = Emulator(200.0, "pose")
    emu.plug()
    emu.realtime = False
    writer = threading.Thread(target=emu._write, args=(b"\0" * (1 << 20),), daemon=True)  # nobody reads the port
    writer.start()
    time.sleep(0.2)
    assert writer.is_alive()  # it waits for room, holding the port
    done = threading.Event()
    threading.Thread(target=lambda: (emu.schedule_button(1.0), done.set()), daemon=True).start()
    try:
        assert done.wait(2.0), "scheduling a button waited for the port's reader"
    finally:
        emu._stop.set()
        writer.join(2.0)
        emu.unplug()
