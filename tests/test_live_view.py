"""Live views while recording (recorder/view): MuJoCo's viewer on a virtual X display (Xvfb) and the web page in
headless Chromium, as a person sees them (screenshots), their keys and buttons, the rerun recording, and what the
view draws staying out of the dataset's images."""

import json
import os
import shutil
import signal
import socket
import subprocess
import sys
import time
from urllib.request import urlopen

import mujoco
import numpy as np
import pytest
from PIL import Image, ImageGrab

import envs
from conftest import cli, gloverec, wait_for
from recorder.hand.gestures import GESTURES
from recorder.hand.pose import HandPose
from recorder.record.sidecar import read_sidecar
from recorder.view.scene import GHOST_RGBA, Stage, frame_of

# the views draw in the idle scheduling class, with the CPU the recording leaves: the tests that look at what they
# drew run alone (serial); the others run with the rest
SERIAL = pytest.mark.serial

SCREENSHOTS = os.environ.get("GLOVEREC_SCREENSHOTS")  # a folder: keep the screenshots (docs/recording.md uses them)


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _keep(image: Image.Image, name: str) -> None:
    if SCREENSHOTS:
        os.makedirs(SCREENSHOTS, exist_ok=True)
        image.save(os.path.join(SCREENSHOTS, name))


def _skin(pixels: np.ndarray) -> int:
    """How many pixels have the hands' skin colour (robot glovehand and the human hand)."""
    r, g, b = (pixels[..., i].astype(int) for i in range(3))
    return int(np.count_nonzero((r > 170) & (r - b > 40) & (g > 110) & (g < r)))


class Recording:
    """`gloverec record` in real time from the emulated glove, its stderr collected line by line."""

    def __init__(self, root, *args, env=None):
        import threading

        self.proc = subprocess.Popen(
            [sys.executable, "-m", "recorder.cli", "record", "--root", str(root), "--repo-id", "test/view", "--json",
             "--realtime", *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE, stdin=subprocess.DEVNULL,
            text=True, env=env)  # fmt: skip
        self.lines: list[str] = []
        self._t = threading.Thread(target=lambda: self.lines.extend(iter(self.proc.stderr.readline, "")), daemon=True)
        self._t.start()

    def wait_for(self, text, timeout=90):
        assert wait_for(lambda: any(text in ln for ln in self.lines), timeout), "".join(self.lines)

    def finish(self, timeout=120) -> dict:
        out = self.proc.stdout.read()
        self.proc.wait(timeout)
        self._t.join(5)
        assert self.proc.returncode == 0, "".join(self.lines)
        return json.loads(out.strip().splitlines()[-1])


@pytest.fixture(scope="module")
def display():
    """A virtual X display (Debian's xvfb; `make test` installs it)."""
    number = 90 + os.getpid() % 50
    xvfb = subprocess.Popen(["Xvfb", f":{number}", "-screen", "0", "1280x800x24", "-nolisten", "tcp"],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)  # fmt: skip
    assert wait_for(lambda: os.path.exists(f"/tmp/.X11-unix/X{number}"), 10), "Xvfb did not start"
    yield f":{number}"
    xvfb.terminate()
    xvfb.wait(10)


@SERIAL
@pytest.mark.process
def test_native_view_shows_the_scene_and_its_key_ends_the_episode(display, tmp_path):
    env = dict(os.environ, DISPLAY=display)
    rec = Recording(tmp_path / "ds", "--task", "grasp", "--episodes", "2", "--episode-time-s", "12",
                    "--reset-time-s", "1", "--view", "native", env=env)  # fmt: skip
    rec.wait_for("episode 0 started")
    time.sleep(2.0)
    shot = np.asarray(ImageGrab.grab(xdisplay=display))
    _keep(Image.fromarray(shot), "native.png")
    window = subprocess.run(["xdotool", "search", "--name", "MuJoCo"], capture_output=True, text=True, env=env)
    wid = window.stdout.split()[-1]
    subprocess.run(["xdotool", "key", "--window", wid, "F9"], env=env, check=True)  # the view's "next"
    summary = rec.finish()
    side = read_sidecar(tmp_path / "ds")
    assert summary["episodes_saved"] == 2
    assert side[0]["frames"] < 12 * 30 - 30, side[0]["frames"]  # ended by the key, well before its 12 s
    # the window holds the scene: the robot hand and the human hand in skin colour, the overlay text in white
    assert _skin(shot) > 1500, _skin(shot)
    text = shot[:120, :500]
    assert np.count_nonzero(text.min(axis=2) > 200) > 500  # the status lines, white on the view


@SERIAL
@pytest.mark.process
def test_web_view_in_a_browser(tmp_path):
    from selenium import webdriver
    from selenium.webdriver.chrome.options import Options
    from selenium.webdriver.chrome.service import Service

    port = _free_port()
    rec = Recording(tmp_path / "ds", "--task", "grasp", "--episodes", "2", "--episode-time-s", "12",
                    "--reset-time-s", "1", "--view", f"web:{port}")  # fmt: skip
    rec.wait_for(f"live view: http://127.0.0.1:{port}/")
    rec.wait_for("episode 0 started")
    url = f"http://127.0.0.1:{port}"
    time.sleep(1.0)
    assert json.loads(urlopen(f"{url}/status", timeout=30).read())["frames"] == 0  # no page: nothing drawn
    assert urlopen(f"{url}/frame.jpg", timeout=30).read()[:2] == b"\xff\xd8"  # a JPEG drawn for the request
    drawn = json.loads(urlopen(f"{url}/status", timeout=30).read())["frames"]
    assert drawn >= 1, drawn
    options = Options()
    for flag in (
        "--headless=new",
        "--no-sandbox",
        "--disable-gpu",
        "--disable-background-networking",
        "--disable-component-update",
        "--disable-sync",
        "--no-first-run",
        "--window-size=900,800",
    ):
        options.add_argument(flag)  # fmt: skip
    options.binary_location = shutil.which("chromium") or "/usr/bin/chromium"
    browser = webdriver.Chrome(options=options, service=Service(shutil.which("chromedriver")))
    try:
        browser.get(f"http://127.0.0.1:{port}/")
        assert wait_for(lambda: "recording" in browser.find_element("id", "status").text, 20)
        time.sleep(1.0)
        path = tmp_path / "web.png"
        browser.save_screenshot(str(path))
        shot = Image.open(path).convert("RGB")
        _keep(shot, "web.png")
        assert _skin(np.asarray(shot)) > 1500  # the scene streams into the page
        status = browser.find_element("id", "status").text
        assert "grasp the" in status and "glove" in status, status
        # the page's own keys (the terminal's), never the native view's F-keys, which a browser keeps for itself
        assert "→ n Enter next" in status and "Esc q stop" in status and "F9" not in status, status
        assert browser.find_element("id", "next").text == "next (→ n Enter)"
        browser.find_element("tag name", "body").send_keys("n")  # ends the episode
        rec.wait_for("episode 0 saved", 60)
        pid = browser.service.process.pid
    finally:
        browser.quit()
    assert pid  # the browser went away mid-session: the recording goes on
    summary = rec.finish()
    side = read_sidecar(tmp_path / "ds")
    assert summary["episodes_saved"] == 2 and side[0]["frames"] < 12 * 30 - 30 and side[1]["frames"] == 12 * 30
    assert summary["view_frames"] > drawn, summary  # and for the page's stream


@pytest.mark.process
def test_killing_the_browser_leaves_the_recording_running(tmp_path):
    port = _free_port()
    rec = Recording(tmp_path / "ds", "--episodes", "3", "--view", f"web:{port}", "--reset-time-s", "0.5")
    rec.wait_for("episode 0 started")
    chromium = subprocess.Popen(
        [shutil.which("chromium"), "--headless=new", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
         "--no-first-run", f"--user-data-dir={tmp_path / 'profile'}", f"http://127.0.0.1:{port}/"],
        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)  # fmt: skip
    time.sleep(3.0)
    chromium.send_signal(signal.SIGKILL)
    chromium.wait(10)
    assert rec.finish()["episodes_saved"] == 3


@SERIAL
@pytest.mark.process
def test_rerun_view_records_joints_scene_and_glove(tmp_path):
    import rerun as rr

    rrd = tmp_path / "view.rrd"
    r = gloverec("record", "--root", str(tmp_path / "ds"), "--repo-id", "test/rerun", "--episodes", "2", "--json",
                 "--view", f"rerun:save:{rrd}", timeout=240)  # fmt: skip
    assert r.returncode == 0, r.stderr
    names = {c.entity_path for c in rr.experimental.RrdReader(str(rrd)).store().schema().component_columns()}
    assert {"/scene", "/glove/rate_hz", "/joints/index_pip/target", "/joints/index_pip/state"} <= names


def test_both_hands_are_labelled_in_the_view():
    import mujoco

    stage = Stage("grasp", "glovehand")
    env = stage.env
    pose = HandPose(np.zeros(20), np.array([1.0, 0, 0, 0]), np.ones(20, bool), 0.0, 0, 0)
    stage.apply(frame_of(env, {}, pose))
    scene = mujoco.MjvScene(stage.model, maxgeom=2000)
    mujoco.mjv_updateScene(stage.model, stage.data, mujoco.MjvOption(), None, mujoco.MjvCamera(),
                           mujoco.mjtCatBit.mjCAT_ALL, scene)  # fmt: skip
    stage.decorate(scene, mujoco.MjvOption())
    labels = [scene.geoms[i].label for i in range(scene.ngeom) if scene.geoms[i].label]
    assert labels == ["robot", "your hand (glove)"]
    stage.show_hand = False
    scene.ngeom = 0
    stage.decorate(scene, mujoco.MjvOption())
    assert [scene.geoms[i].label for i in range(scene.ngeom) if scene.geoms[i].label] == ["robot"]


def test_the_ghost_and_the_human_hand_stay_out_of_the_cameras():
    """The view draws them into its own scene only: the task's camera images never have them."""
    env = envs.make("pose", "glovehand", cameras=("front",), image_size=(240, 320)).unwrapped
    obs, _ = env.reset(seed=3)
    for _ in range(5):
        obs, *_ = env.step(np.zeros(env.action_space.shape, np.float32))
    pose = HandPose(GESTURES["fist"], np.array([1.0, 0.0, 0.0, 0.0]), np.ones(20, bool))
    stage = Stage("pose", "glovehand")
    stage.apply(frame_of(env, {"seed": 3}, pose))
    renderer = mujoco.Renderer(stage.model, 240, 320)
    opt = mujoco.MjvOption()
    renderer.update_scene(stage.data, camera="front", scene_option=opt)
    plain = renderer.render().copy()
    stage.decorate(renderer.scene, opt)
    drawn = renderer.render()
    camera = obs["observation.images.front"]
    assert np.abs(plain.astype(int) - camera.astype(int)).mean() < 2.0  # the same scene, as the camera sees it
    assert np.abs(drawn.astype(int) - camera.astype(int)).mean() > 2.0  # the view adds to it
    ghost = (GHOST_RGBA[:3] * 255).astype(int)
    bluish = lambda im: np.count_nonzero((im[..., 2].astype(int) - im[..., 0]) > 60)  # noqa: E731
    assert bluish(camera) < 50 < bluish(drawn), (bluish(camera), bluish(drawn), ghost)


@pytest.mark.process
def test_bad_views_are_one_line(tmp_path):
    r = cli("record", "--view", "hologram", "--root", str(tmp_path / "a"))
    assert r.returncode == 2 and "unknown view 'hologram'; valid: native, web, rerun, none" in r.stderr
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    r = gloverec("record", "--view", "native", "--root", str(tmp_path / "b"), env=env)
    assert r.returncode == 1 and r.stderr.count("\n") == 1 and "--view web" in r.stderr, r.stderr
    with socket.socket() as busy:
        busy.bind(("127.0.0.1", 0))
        busy.listen()
        port = busy.getsockname()[1]
        r = gloverec("record", "--view", f"web:{port}", "--root", str(tmp_path / "c"))
    assert r.returncode == 1 and r.stderr.count("\n") == 1 and f"127.0.0.1:{port}" in r.stderr, r.stderr
    r = cli("view", "--glove", "emulator", "--view", "web:99999")
    assert r.returncode == 2 and "expected web, web:PORT or web:HOST:PORT" in r.stderr
