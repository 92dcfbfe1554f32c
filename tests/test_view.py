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
