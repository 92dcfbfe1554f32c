"""The tracked wrist in the live views (issue 24, recorder/view/wrist.py): the frame carries the fused palm pose
and its quality, the scene draws the palm, the workspace's bounds and the side it is pressed against, the status
says a lost marker and the edge, `gloverec view --wrist` follows a tracker, and tasks without a tracked wrist look
as they did. The web page as a person sees it is in the last test (its screenshot: docs/images/relocate_wrist.png)."""

import json
import os
import shutil
import socket
import threading
import time
from types import SimpleNamespace

import mujoco
import numpy as np
import pytest
from PIL import Image

from conftest import cli, wait_for
from recorder import quat
from recorder.hand.pose import HandPose
from recorder.view import overlay, wrist
from recorder.view.scene import BOUNDS_RGBA, EDGE_RGBA, HAND_OFFSET, WRIST_RGBA, Stage, frame_of, free_camera
from recorder.view.state import SharedFrame
from recorder.wrist.format import WristPose
from recorder.wrist.fusion import FusedWrist, FusionConfig, WristFusion

SCREENSHOTS = os.environ.get("GLOVEREC_SCREENSHOTS")  # a folder: keep the screenshot (docs/wrist.md uses it)
POSE = HandPose(np.zeros(20), quat.IDENTITY.copy(), np.ones(20, bool), 0.0, 0, 0)


@pytest.fixture(scope="module")
def relocate():
    stage = Stage("relocate", "glovehand", {"terminate_on_success": False})
    stage.env.reset(seed=0)
    return stage


def _geoms(stage: Stage, frame) -> list:
    """(rgba, label) of every geom the view adds to the scene for ``frame``."""
    stage.apply(frame)
    scene = mujoco.MjvScene(stage.model, maxgeom=2000)
    mujoco.mjv_updateScene(stage.model, stage.data, mujoco.MjvOption(), None, mujoco.MjvCamera(),
                           mujoco.mjtCatBit.mjCAT_ALL, scene)  # fmt: skip
    first = scene.ngeom
    stage.decorate(scene, mujoco.MjvOption())
    return [(tuple(np.round(scene.geoms[i].rgba, 3)), scene.geoms[i].label) for i in range(first, scene.ngeom)]


def _count(geoms, rgba) -> int:
    return sum(g[0] == tuple(np.round(rgba, 3)) for g in geoms)


def test_the_frame_carries_the_wrist_and_its_quality_through_the_shared_slot(relocate):
    env = relocate.env
    fused = FusedWrist(np.array([0.05, -0.02, 0.2]), quat.from_axis_angle([0, 0, 1.0], 0.3), True, 0.04)
    status = {"seed": 0, "wrist": wrist.status(fused, env.base_bounds, 3, 100, "marker")}
    shared = SharedFrame.create(relocate.layout)
    reader = SharedFrame.attach(shared.path, relocate.layout)
    try:
        shared.write(frame_of(env, status, POSE, fused))
        got = reader.read()
        np.testing.assert_allclose(got.wrist, np.concatenate((fused.position, fused.quat)))
        assert got.status["wrist"] == {"state": "tracked", "source": "marker", "tracked_share": 0.97, "age_s": 0.04,
                                       "edge": []}  # fmt: skip
        shared.write(frame_of(env, {"seed": 0}, POSE))  # no tracked wrist: none in the frame
        got = reader.read()
        assert "wrist" not in got.status and np.allclose(got.wrist, [0, 0, 0, 1, 0, 0, 0])
    finally:
        reader.close()
        shared.close()


def test_a_lost_marker_shows_as_lost_then_catching_up_then_tracked():
    f = WristFusion(FusionConfig(camera_noise=False))
    bounds = (np.array([-0.3, -0.3, 0.02]), np.array([0.3, 0.3, 0.35]))
    start = np.array([0.0, 0.0, 0.15])

    def seen(t, p):
        f.imu(t, quat.IDENTITY)
        f.tracker(WristPose(0, t, np.array(p, float), quat.IDENTITY.copy()))

    seen(0.0, [0.0, 0.0, 0.5])
    assert f.zero(0.0, start)
    states = []
    for k in range(1, 91):  # 3 s at 30 Hz: seen for 1 s, hidden for 1 s, seen 10 cm away
        t = k / 30
        if not 1.0 < t <= 2.0:
            seen(t, [0.0, 0.0, 0.5] if t <= 1.0 else [0.1, 0.0, 0.5])
        states.append(wrist.status(f.pose(t), bounds, 0, k, "marker"))
    names = [s["state"] for s in states]
    assert names[29] == "tracked" and names[59] == "lost" and names[65] == "catching up" and names[-1] == "tracked"
    rows = dict(overlay.lines({"wrist": states[59]}))
    assert rows["wrist"].startswith("MARKER LOST 1.0 s ago: hold still"), rows
    assert overlay.wrist_brief(states[59]) == "wrist LOST 1.0 s"
    assert "catching up" in dict(overlay.lines({"wrist": states[65]}))["wrist"]
    assert "TRACKER LOST" in dict(overlay.lines({"wrist": dict(states[59], source="udp")}))["wrist"]


def test_the_bounds_the_pressed_side_and_the_palm_are_drawn(relocate):
    env = relocate.env
    lo, hi = env.base_bounds
    inside = FusedWrist((lo + hi) / 2, quat.IDENTITY.copy(), True, 0.03)
    geoms = _geoms(relocate, frame_of(env, {"seed": 0, "wrist": wrist.status(inside, env.base_bounds, 0, 1, "udp")},
                                      POSE, inside))  # fmt: skip
    assert _count(geoms, BOUNDS_RGBA) == 12  # the box's edges
    assert _count(geoms, WRIST_RGBA["tracked"]) >= 3 and _count(geoms, EDGE_RGBA) == 0  # the palm, nothing pressed
    out = FusedWrist(np.array([hi[0] + 0.1, 0.0, lo[2] - 0.05]), quat.IDENTITY.copy(), False, 1.5)
    status = {"seed": 0, "wrist": wrist.status(out, env.base_bounds, 45, 90, "marker")}
    assert status["wrist"]["edge"] == ["x+", "z-"] and status["wrist"]["state"] == "lost"
    geoms = _geoms(relocate, frame_of(env, status, POSE, out))
    assert _count(geoms, EDGE_RGBA) == 2 * 4 + 1  # each pressed side's outline, and the line to the held palm
    assert _count(geoms, WRIST_RGBA["lost"]) >= 3 and "marker lost: hold still" in [g[1] for g in geoms]
    rows = dict(overlay.lines(status))
    assert rows["workspace"] == "at its edge (front, bottom): the robot's palm stops there"
    assert overlay.wrist_brief(status["wrist"]) == "wrist LOST 1.5 s at the edge"


def test_a_task_without_a_tracked_wrist_looks_as_before():
    stage = Stage("grasp", "glovehand")
    stage.env.reset(seed=0)
    status = {"seed": 0, "task": "grasp the box", "glove": {"rate_hz": 200.0}}
    geoms = _geoms(stage, frame_of(stage.env, status, POSE))
    assert [g[1] for g in geoms if g[1]] == ["robot", "your hand (glove)"]
    assert _count(geoms, BOUNDS_RGBA) == 0 and _count(geoms, EDGE_RGBA) == 0
    assert [r[0] for r in overlay.lines(status)] == ["task", "glove", "keys"]
    cam = free_camera(stage)
    np.testing.assert_allclose(cam.lookat, stage.workspace + 0.5 * HAND_OFFSET)
    assert cam.distance == stage.env.view_distance_m
    # a free-wrist task's camera stands back to show the whole workspace, the human hand drawn beside it
    free = Stage("grasp", "glovehand", {"base_position": True})
    assert free_camera(free).distance > cam.distance and free.hand_at[1] > free.env.base_bounds[1][1]


def test_the_terminal_line_gets_the_wrist_when_it_has_room(relocate):
    from recorder.record.live import LiveView

    cfg = SimpleNamespace(fps=30, task="relocate", robot="glovehand", episodes=1,
                          wrist_config=SimpleNamespace(kind="marker"))  # fmt: skip
    live = LiveView("none", cfg, relocate.env, glove=None, control=SimpleNamespace(request=None), root=None,
                    say=lambda line: None)  # fmt: skip
    assert live.with_wrist("episode 0  frame 3/240", None) == "episode 0  frame 3/240"  # no wrist yet
    lost = FusedWrist(relocate.env.palm_pose()[0], quat.IDENTITY.copy(), False, 0.9)
    live.recording(0, 9, 240, SimpleNamespace(wrist_lost=5), lost)
    assert live.wrist["state"] == "lost" and live.wrist["tracked_share"] == 0.5
    assert live.with_wrist("episode 0  frame 10/240", None) == "episode 0  frame 10/240  wrist LOST 0.9 s"
    assert live.with_wrist("x" * 70, None) == "x" * 70  # no room in 80 columns


def _send_poses(port: int, seconds: float, stop: threading.Event, lose: threading.Event | None = None) -> None:
    """A tracker at 60 Hz on udp ``port``: still for a second, then moving right (its -y) at 0.3 m/s to 0.45 m,
    where it stays; lost (its poses untracked) once ``lose`` is set: when the test has seen it there, not after a
    time that a loaded machine's recording may not have caught up with."""
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    t0, seq = time.time(), 0
    while time.time() - t0 < seconds and not stop.is_set():
        s = time.time() - t0
        p = [0.0, -min(0.45, 0.3 * max(0.0, s - 1.0)), 0.5]
        tracked = lose is None or not lose.is_set()
        msg = {"seq": seq, "t": time.time(), "p": p, "q": [1, 0, 0, 0], "tracked": tracked}
        sock.sendto(json.dumps(msg).encode(), ("127.0.0.1", port))
        seq += 1
        time.sleep(1 / 60)
    sock.close()


def _free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_gloverec_view_follows_a_tracker_and_a_free_wrist_task_needs_one(tmp_path):
    r = cli("view", "--glove", "emulator", "--task", "relocate", "--video", str(tmp_path / "none.mp4"))
    assert r.returncode == 1 and r.stderr.count("\n") == 1, r.stderr
    assert "the relocate task needs a tracked wrist: pass --wrist udp:PORT or marker:CAMERA" in r.stderr
    for bad, code, says in (
        ("laser:3", 2, "unknown wrist source 'laser:3'"),  # checked as its flag is parsed, as record's
        ("marker:emulated", 1, "films `gloverec record`"),
    ):
        r = cli("view", "--glove", "emulator", "--task", "relocate", "--wrist", bad, "--video", str(tmp_path / "x.mp4"))
        assert r.returncode == code and r.stderr.count("\n") == 1 and says in r.stderr, r.stderr
    port, stop = _free_port(), threading.Event()
    sender = threading.Thread(target=_send_poses, args=(port, 30.0, stop), daemon=True)
    sender.start()
    try:
        video = tmp_path / "relocate.mp4"
        r = cli("view", "--glove", "emulator", "--task", "relocate", "--wrist", f"udp:{port}", "--video", str(video),
                "--duration", "1")  # fmt: skip
    finally:
        stop.set()
        sender.join(2)
    assert r.returncode == 0, r.stderr
    assert "30 frames of glovehand (relocate)" in r.stdout and "wrist tracked" in r.stdout, r.stdout
    import imageio.v2 as imageio

    last = imageio.mimread(video, memtest=False)[-1].astype(int)
    green = (last[..., 1] > 180) & (last[..., 0] < 120) & (last[..., 2] < 150)  # the tracked palm's plate
    assert np.count_nonzero(green) > 30, np.count_nonzero(green)


@pytest.mark.process
def test_the_web_page_shows_a_lost_tracker_at_the_workspace_s_edge(tmp_path):
    """A relocate recording from a UDP tracker that moves the wrist right past the workspace's side and is then
    lost, as the web page shows it in headless Chromium."""
    from selenium import webdriver
    from selenium.common.exceptions import WebDriverException
    from selenium.webdriver.chrome.options import Options
    from selenium.webdriver.chrome.service import Service
    from test_live_view import HANG_S, LONG_S, Recording, _free_port as free_tcp_port, _until

    port, udp, stop, lose = free_tcp_port(), _free_port(), threading.Event(), threading.Event()
    with Recording(tmp_path / "ds", "--task", "relocate", "--episodes", "1", "--episode-time-s", str(LONG_S),
                   "--view", f"web:{port}", "--wrist", f"udp:{udp}", control=True) as rec:  # fmt: skip
        rec.wait_for("episode 0 started")  # the episode's zero waits for the tracker's first pose
        sender = threading.Thread(target=_send_poses, args=(udp, LONG_S, stop, lose), daemon=True)
        sender.start()
        options = Options()
        for flag in ("--headless=new", "--no-sandbox", "--disable-gpu", "--no-first-run", "--window-size=680,940"):
            options.add_argument(flag)
        options.binary_location = shutil.which("chromium") or "/usr/bin/chromium"
        browser = webdriver.Chrome(options=options, service=Service(shutil.which("chromedriver")))
        path = tmp_path / "relocate_wrist.png"

        def text(selector: str) -> str:
            """An element's text; empty while the page has none (the status table is rewritten 4 times a second)."""
            try:
                return browser.find_element("css selector", selector).text
            except WebDriverException:
                return ""

        def screenshot():
            browser.save_screenshot(str(path))
            return np.asarray(Image.open(path).convert("RGB")), text("tr.warn")

        try:
            browser.get(f"http://127.0.0.1:{port}/")
            assert wait_for(lambda: "at its edge (right)" in text("#status"), HANG_S), text("#status")  # tracked there
            lose.set()
            assert wait_for(lambda: "TRACKER LOST" in text("#status") and "at its edge (right)" in text("#status"),
                            HANG_S), text("#status")  # fmt: skip
            shot, warn = _until(screenshot, lambda got: _shown(*_plates(got[0])) and got[1].startswith("wrist"))
        finally:
            browser.quit()
            stop.set()
            sender.join(2)
        rec.send("next")  # the episode has shown what the test looks for: ended from the terminal
        summary = rec.finish()
    if SCREENSHOTS:
        os.makedirs(SCREENSHOTS, exist_ok=True)
        Image.fromarray(shot).save(os.path.join(SCREENSHOTS, "relocate_wrist.png"))
    assert warn.startswith("wrist TRACKER LOST"), warn
    assert _shown(*_plates(shot)), _plates(shot)
    assert summary["episodes_saved"] == 1


def _plates(shot: np.ndarray) -> tuple[int, int]:
    """The pixels of the lost palm's plate (red) and of the side of the workspace it is pressed on (magenta), in
    the page's scene."""
    scene = shot[16:496, 16:656].astype(int)
    red = (scene[..., 0] > 200) & (scene[..., 1] < 80) & (scene[..., 2] < 80)
    magenta = (scene[..., 0] > 180) & (scene[..., 1] < 120) & (scene[..., 2] > 170)
    return int(np.count_nonzero(red)), int(np.count_nonzero(magenta))


def _shown(red: int, magenta: int) -> bool:
    return red > 30 and magenta > 200
