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
from recorder.view.process import PRIORITY_ENV
from recorder.view.scene import GHOST_RGBA, Stage, frame_of

# The views draw in the idle scheduling class by default, with only the CPU the recording leaves: on a loaded
# machine (the rest of the suite, a training run beside it) they would draw nothing. The recordings here run them
# at normal priority, so that what a test looks at is drawn whatever else runs.
KEEP_UP = {PRIORITY_ENV: "normal"}
# Episodes longer than a test may run (pytest's timeout, pyproject.toml): none ends by its time while a test looks
# at it, however slow a browser or a screenshot is; the key under test, or the test's own line on the recording's
# stdin once it has seen what it waits for, ends each one.
LONG_S = 600
# How long a test waits for what it looks for before it fails: a guard against hanging, not a bound (a recording's
# start-up took 50 s beside a full suite and two busy loops on this 2-core machine).
HANG_S = 180

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
    """`gloverec record` in real time from the emulated glove, its stderr collected line by line, its live view at
    normal priority (KEEP_UP). ``control``: a pipe on its stdin, for ``send`` (lines: next, stop;
    recorder/record/control.py), else no input. As a context manager it kills the recording if the test leaves
    it running (a failed test: its long episodes would otherwise go on)."""

    def __init__(self, root, *args, env=None, control=False):
        import threading

        env = dict(os.environ if env is None else env, **KEEP_UP)
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "recorder.cli", "record", "--root", str(root), "--repo-id", "test/view", "--json",
             "--realtime", *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
            stdin=subprocess.PIPE if control else subprocess.DEVNULL, text=True, env=env)  # fmt: skip
        self.lines: list[str] = []
        self._t = threading.Thread(target=lambda: self.lines.extend(iter(self.proc.stderr.readline, "")), daemon=True)
        self._t.start()

    def __enter__(self):
        return self

    def __exit__(self, *exc) -> None:
        if self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait(30)

    def wait_for(self, text, timeout=HANG_S):
        assert wait_for(lambda: any(text in ln for ln in self.lines), timeout), "".join(self.lines)

    def send(self, line: str) -> None:
        """A control line on the recording's stdin, as a script would type it."""
        self.proc.stdin.write(line + "\n")
        self.proc.stdin.flush()

    def finish(self, timeout=120) -> dict:
        if self.proc.stdin is not None:
            self.proc.stdin.close()
        out = self.proc.stdout.read()
        self.proc.wait(timeout)
        self._t.join(5)
        assert self.proc.returncode == 0, "".join(self.lines)
        return json.loads(out.strip().splitlines()[-1])


def _until(shoot, good, timeout: float = HANG_S):
    """Screenshots from ``shoot()`` until one shows what ``good(shot)`` looks for (the view has drawn the newest
    frame), then that one; after ``timeout``, the last one, for the test's assertions to describe."""
    end = time.monotonic() + timeout
    while True:
        shot = shoot()
        if good(shot) or time.monotonic() > end:
            return shot
        time.sleep(0.2)


def _white_text(shot: np.ndarray) -> int:
    """How many pixels of the native view's status lines (white, top left) there are."""
    return int(np.count_nonzero(shot[:120, :500].min(axis=2) > 200))


@pytest.fixture(scope="module")
def display():
    """A virtual X display (Debian's xvfb; `make test` installs it), on a display number Xvfb chose free and
    wrote back once it accepts clients (-displayfd): no other run's display, no guess at its start-up time."""
    read, write = os.pipe()
    xvfb = subprocess.Popen(["Xvfb", "-displayfd", str(write), "-screen", "0", "1280x800x24", "-nolisten", "tcp"],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, pass_fds=(write,))  # fmt: skip
    os.close(write)
    number = b""
    while not number.endswith(b"\n"):
        chunk = os.read(read, 16)  # empty: Xvfb ended without a display
        assert chunk, f"Xvfb did not start (exit {xvfb.wait(10)})"
        number += chunk
    os.close(read)
    yield f":{int(number)}"
    xvfb.terminate()
    xvfb.wait(10)


@pytest.mark.process
def test_native_view_shows_the_scene_and_its_key_ends_the_episode(display, tmp_path):
    env = dict(os.environ, DISPLAY=display)
    with Recording(tmp_path / "ds", "--task", "grasp", "--episodes", "2", "--episode-time-s", str(LONG_S),
                   "--reset-time-s", "1", "--view", "native", env=env, control=True) as rec:  # fmt: skip
        rec.wait_for("episode 0 started")
        # the window holds the scene: the robot hand and the human hand in skin colour, the overlay text in white
        shot = _until(lambda: np.asarray(ImageGrab.grab(xdisplay=display)),
                      lambda shot: _skin(shot) > 1500 and _white_text(shot) > 500)  # fmt: skip
        _keep(Image.fromarray(shot), "native.png")
        assert _skin(shot) > 1500, _skin(shot)
        assert _white_text(shot) > 500, _white_text(shot)  # the status lines, white on the view
        window = subprocess.run(["xdotool", "search", "--name", "MuJoCo"], capture_output=True, text=True, env=env)
        wid = window.stdout.split()[-1]
        subprocess.run(["xdotool", "key", "--window", wid, "F9"], env=env, check=True)  # the view's "next"
        rec.wait_for("episode 1 started")
        rec.send("stop")  # the second episode: ended from the terminal once it runs
        summary = rec.finish()
    side = read_sidecar(tmp_path / "ds")
    assert summary["episodes_saved"] == 2
    assert side[0]["frames"] < LONG_S * 30 - 30, side[0]["frames"]  # ended by the key, well before its time
    assert 0 < side[1]["frames"] < LONG_S * 30, side[1]["frames"]  # ended by stop, and saved


def _status(port: int) -> dict:
    """The web view's /status: its rows and the frames it has drawn."""
    return json.loads(urlopen(f"http://127.0.0.1:{port}/status", timeout=30).read())


@pytest.mark.process
def test_web_view_in_a_browser(tmp_path):
    from selenium import webdriver
    from selenium.webdriver.chrome.options import Options
    from selenium.webdriver.chrome.service import Service

    port = _free_port()
    with Recording(tmp_path / "ds", "--task", "grasp", "--episodes", "2", "--episode-time-s", str(LONG_S),
                   "--reset-time-s", "1", "--view", f"web:{port}", control=True) as rec:  # fmt: skip
        rec.wait_for(f"live view: http://127.0.0.1:{port}/")
        rec.wait_for("episode 0 started")
        url = f"http://127.0.0.1:{port}"
        seen: list = []  # the status rows of the recording, as the view kept them current

        def recording_went_on() -> bool:
            rows = _status(port)["rows"]
            if any(k == "episode" and "recording" in v for k, v in rows) and rows not in seen:
                seen.append(rows)
            return len(seen) >= 2

        assert wait_for(recording_went_on, HANG_S, 0.1), seen  # the view follows the recording...
        assert _status(port)["frames"] == 0  # ... and, with no page, draws nothing
        assert urlopen(f"{url}/frame.jpg", timeout=60).read()[:2] == b"\xff\xd8"  # a JPEG drawn for the request
        drawn = _status(port)["frames"]
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
            assert wait_for(lambda: "recording" in browser.find_element("id", "status").text, HANG_S)
            path = tmp_path / "web.png"

            def screenshot() -> np.ndarray:
                browser.save_screenshot(str(path))
                return np.asarray(Image.open(path).convert("RGB"))

            shot = _until(screenshot, lambda shot: _skin(shot) > 1500)
            _keep(Image.fromarray(shot), "web.png")
            assert _skin(shot) > 1500, _skin(shot)  # the scene streams into the page
            status = browser.find_element("id", "status").text
            assert "grasp the" in status and "glove" in status, status
            # the page's own keys (the terminal's), never the native view's F-keys, which a browser keeps for itself
            assert "→ n Enter next" in status and "Esc q stop" in status and "F9" not in status, status
            assert browser.find_element("id", "next").text == "next (→ n Enter)"
            assert not browser.find_element("id", "takeover").is_displayed()  # a plain recording: nothing to take over
            browser.find_element("tag name", "body").send_keys("n")  # ends the episode
            rec.wait_for("episode 1 started")
            pid = browser.service.process.pid
        finally:
            browser.quit()
        assert pid  # the browser went away mid-session: the recording goes on
        rec.send("stop")  # the second episode: ended from the terminal once the browser has gone
        summary = rec.finish()
    side = read_sidecar(tmp_path / "ds")
    assert summary["episodes_saved"] == 2, summary
    assert side[0]["frames"] < LONG_S * 30 - 30, side[0]["frames"]  # ended by the page's key, well before its time
    assert 0 < side[1]["frames"] < LONG_S * 30, side[1]["frames"]  # ended by stop, and saved
    assert summary["view_frames"] > drawn, summary  # and for the page's stream


@pytest.mark.process
def test_killing_the_browser_leaves_the_recording_running(tmp_path):
    port = _free_port()
    with Recording(tmp_path / "ds", "--task", "grasp", "--episodes", "3", "--episode-time-s", str(LONG_S),
                   "--view", f"web:{port}", "--reset-time-s", "0.5", control=True) as rec:  # fmt: skip
        rec.wait_for("episode 0 started")
        chromium = subprocess.Popen(
            [shutil.which("chromium"), "--headless=new", "--no-sandbox", "--disable-gpu",
             "--disable-background-networking", "--no-first-run", f"--user-data-dir={tmp_path / 'profile'}",
             f"http://127.0.0.1:{port}/"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)  # fmt: skip
        try:  # the page is open: its stream has the view drawing (it draws for nobody else here)
            assert wait_for(lambda: _status(port)["frames"] > 0, HANG_S, 0.1), "".join(rec.lines)
        finally:
            chromium.send_signal(signal.SIGKILL)
            chromium.wait(10)
        for k in range(3):  # the recording goes on: each episode ended from the terminal as it runs
            rec.wait_for(f"episode {k} started")
            rec.send("next")
        assert rec.finish()["episodes_saved"] == 3


@pytest.mark.process
def test_rerun_view_records_joints_scene_and_glove(tmp_path):
    import rerun as rr

    rrd = tmp_path / "view.rrd"
    r = gloverec("record", "--root", str(tmp_path / "ds"), "--repo-id", "test/rerun", "--episodes", "2", "--json",
                 "--view", f"rerun:save:{rrd}", env=dict(os.environ, **KEEP_UP), timeout=240)  # fmt: skip
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


@pytest.mark.parametrize("beside_realtime", [False, True])
@pytest.mark.parametrize("setting", [None, "idle", "normal", "bogus"])
def test_the_view_takes_only_idle_cpu_unless_told_to_keep_up(setting, beside_realtime, monkeypatch):
    """The view process's first act (`_step_aside`), run in a forked child (the idle class cannot be left without
    privileges): the idle scheduling class by default, the command's own beside a recording whose loop runs in the
    real-time class or with GLOVEREC_VIEW_PRIORITY=normal; a command refuses any other value in one line before it
    starts a view."""
    import warnings

    from recorder.config import ConfigError
    from recorder.view import process

    if setting is None:
        monkeypatch.delenv(PRIORITY_ENV, raising=False)
    else:
        monkeypatch.setenv(PRIORITY_ENV, setting)
    if setting == "bogus":
        with pytest.raises(ConfigError, match="GLOVEREC_VIEW_PRIORITY='bogus': valid: idle, normal"):
            process.check(process.ViewSpec("web", port=_free_port()))
        return
    process.check(process.ViewSpec("web", port=_free_port()))
    read, write = os.pipe()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)  # fork() with threads: the child makes two system calls
        pid = os.fork()
    if pid == 0:
        try:
            process._step_aside(beside_realtime)
            os.write(write, str(os.sched_getscheduler(0)).encode())
        finally:
            os._exit(0)
    os.close(write)
    os.waitpid(pid, 0)
    got = int(os.read(read, 16) or b"-1")
    os.close(read)
    normal = setting == "normal" or (setting is None and beside_realtime)
    assert got == (os.sched_getscheduler(0) if normal else os.SCHED_IDLE), got
