"""`gloverec view`: the robot hand follows a glove of any wire format (pose, compact, raw frames fused on the
host), rendered to a video headless."""

import imageio.v2 as imageio
import numpy as np
import pytest

from conftest import cli


def _motion(video) -> float:
    """How much the picture changes over the video: mean absolute pixel difference, first frame to the others."""
    frames = np.array(imageio.mimread(video, memtest=False), float)
    assert len(frames) > 10
    return float(np.abs(frames[1:] - frames[0]).mean(axis=(1, 2, 3)).max())


def test_view_of_the_emulated_glove(tmp_path):
    video = tmp_path / "emulator.mp4"
    r = cli("view", "--glove", "emulator", "--video", str(video), "--duration", "2")
    assert r.returncode == 0, r.stderr
    assert "60 frames of glovehand (pose)" in r.stdout
    assert _motion(video) > 1.0


@pytest.mark.parametrize("mode", ["compact", "raw", "json"])
def test_view_follows_compact_raw_and_legacy_gloves(emulator, tmp_path, mode):
    emu = emulator("--output", mode, "--rate", "100")
    video = tmp_path / f"{mode}.mp4"
    r = cli("view", "--glove", f"serial:{emu.port}", "--video", str(video), "--duration", "3")
    assert r.returncode == 0, r.stderr
    glove_frames = int(r.stdout.split(", ")[-1].split()[0])
    assert glove_frames > 100, r.stdout  # poses came through, whatever the wire format
    assert _motion(video) > 1.0  # and the hand moved


def test_view_of_a_silent_port_is_one_line(tmp_path):
    r = cli("view", "--glove", f"mcap:{tmp_path / 'missing.mcap'}", "--video", str(tmp_path / "v.mp4"))
    assert r.returncode == 1 and r.stderr.count("\n") == 1 and "missing.mcap" in r.stderr, r.stderr


def test_a_port_whose_connections_wait_out_time_wait_serves_the_view_again():
    """Re-running `--view web` soon after a browser's session: only TIME-WAIT sockets are left on the port, which the
    view's server may bind (SO_REUSEADDR), so the pre-flight check must not call it in use; a listener still is."""
    import socket

    from recorder.config import ConfigError
    from recorder.view.process import ViewSpec, check

    server = socket.socket()
    server.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    server.bind(("127.0.0.1", 0))
    server.listen()
    port = server.getsockname()[1]
    spec = ViewSpec("web", "127.0.0.1", port)
    with pytest.raises(ConfigError, match=f"cannot serve the view on 127.0.0.1:{port}"):
        check(spec)  # something listens there
    client = socket.create_connection(("127.0.0.1", port))
    accepted, _ = server.accept()
    accepted.close()  # the server's end closes first: it waits out TIME-WAIT on the port
    client.close()
    server.close()
    with socket.socket() as plain, pytest.raises(OSError):
        plain.bind(("127.0.0.1", port))  # a plain bind is refused: what the check did before
    check(spec)
