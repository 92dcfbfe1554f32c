"""`gloverec review` (issue 26): the page in headless Chromium discards, trims and publishes the hub's next
version, which plain LeRobotDataset loads; the player renders a camera-less episode; bad input is one line and
changes nothing."""

from __future__ import annotations

import io
import os
import shutil
import socket
import time

import numpy as np
import pytest
from lerobot.datasets.lerobot_dataset import LeRobotDataset
from PIL import Image

from conftest import POSE_REPO, cli, gloverec, wait_for
from recorder import GloverecError

SCREENSHOTS = os.environ.get("GLOVEREC_SCREENSHOTS")  # a folder: keep the page's screenshot (docs/images/review.png)


def _lengths(ds: LeRobotDataset) -> list[int]:
    return [int(n) for n in ds.meta.episodes["length"]]


@pytest.fixture
def hub(pose_recording, tmp_path):
    src, _ = pose_recording
    hub = tmp_path / "hub"
    assert cli("push", "--repo-id", POSE_REPO, "--root", str(src), "--hub", str(hub)).returncode == 0
    return hub


@pytest.fixture
def review(hub):
    from recorder.review.server import Review
    from recorder.review.session import Session

    server = Review(Session(POSE_REPO, hub=str(hub)), port=0)
    server.start()
    yield server
    server.close()


def _browser():
    from selenium import webdriver
    from selenium.webdriver.chrome.options import Options
    from selenium.webdriver.chrome.service import Service

    options = Options()
    flags = ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
             "--disable-component-update", "--disable-sync", "--no-first-run", "--window-size=1400,900")  # fmt: skip
    for flag in flags:
        options.add_argument(flag)
    options.binary_location = shutil.which("chromium") or "/usr/bin/chromium"
    return webdriver.Chrome(options=options, service=Service(shutil.which("chromedriver")))


@pytest.mark.process
def test_the_page_discards_trims_and_publishes_the_hubs_next_version(review, hub, tmp_path):
    v1 = LeRobotDataset(POSE_REPO, root=hub / f"{POSE_REPO}@v1")
    before = _lengths(v1)
    fps = v1.meta.fps
    browser = _browser()
    try:
        browser.get(review.url)
        shown = lambda: browser.execute_script("return document.body.dataset.firstFrame")  # noqa: E731
        assert wait_for(shown, 20), browser.find_element("id", "msg").text
        frame = browser.find_element("id", "frame")  # a camera-less dataset: rendered from the recording
        assert browser.execute_script("return arguments[0].naturalWidth", frame) == 480
        body = browser.find_element("tag name", "body")

        browser.find_element("css selector", 'tr.ep[data-ep="1"]').click()
        browser.find_element("id", "discard").click()
        assert wait_for(lambda: "deleted 1" in browser.find_element("id", "pending").text, 5)
        browser.find_element("css selector", 'tr.ep[data-ep="2"]').click()
        assert wait_for(lambda: browser.find_element("id", "plots").text, 10)  # the joint plots arrived
        body.send_keys(*["\ue014"] * 15)  # → 15 frames: the cursor at 0.5 s
        assert wait_for(lambda: "frame 15 of" in browser.find_element("id", "time").text, 5)
        body.send_keys("[")  # trim start here
        assert wait_for(lambda: "trimmed 2 to 0.5-end s" in browser.find_element("id", "pending").text, 5)
        time.sleep(0.5)  # the frame at the cursor
        path = tmp_path / "review.png"
        browser.save_screenshot(str(path))
        assert np.asarray(Image.open(path).convert("L")).std() > 20  # a page, not a blank
        if SCREENSHOTS:
            os.makedirs(SCREENSHOTS, exist_ok=True)
            shutil.copy(path, os.path.join(SCREENSHOTS, "review.png"))

        browser.find_element("id", "publish").click()
        assert wait_for(lambda: "published" in browser.find_element("id", "msg").text, 60), browser.find_element(
            "id", "msg"
        ).text
        msg = browser.find_element("id", "msg").text
        assert f"{POSE_REPO} v2: 3 episodes" in msg, msg
        assert "v2" in browser.find_element("id", "title").text  # the page now reviews what it published

        # every episode discarded: one line on the page, and the hub unchanged
        discarded = "return document.querySelectorAll('tr.discard').length"
        for e in range(3):
            browser.find_element("css selector", f'tr.ep[data-ep="{e}"]').click()
            body.send_keys("d")
            assert wait_for(lambda e=e: browser.execute_script(discarded) == e + 1, 5)
        browser.find_element("id", "publish").click()
        assert wait_for(lambda: "every episode is discarded" in browser.find_element("id", "msg").text, 10)
    finally:
        browser.quit()

    v2 = LeRobotDataset(POSE_REPO, root=hub / POSE_REPO)  # the link: the newest
    assert v2.num_episodes == 3 and len(v2) == v2.meta.total_frames
    first = int(np.ceil(0.5 * fps))
    assert _lengths(v2) == [before[0], before[2] - first, before[3]]
    assert _lengths(LeRobotDataset(POSE_REPO, root=hub / f"{POSE_REPO}@v1")) == before  # the old version kept
    assert sorted(p.name for p in (hub / "test").iterdir() if "@" in p.name) == ["pose@v1", "pose@v2"]
    verified = cli("hub", "verify", "--hub", str(hub), "--repo-id", POSE_REPO)
    assert verified.returncode == 0, verified.stdout + verified.stderr


def test_the_player_renders_frames_of_a_camera_less_episode_on_request(pose_recording):
    from recorder.review.frames import Frames
    from recorder.review.session import Session

    src, _ = pose_recording
    session = Session(POSE_REPO, root=str(src))
    frames = Frames(session)
    try:
        k = session.lengths[0] - 1
        first, later = frames.frame(0, 0), frames.frame(0, k)  # stepped from the reset to frame k, no further
        assert frames.at == (0, k)
        a, b = (np.asarray(Image.open(io.BytesIO(j))) for j in (first, later))
        assert a.shape == (360, 480, 3) and np.abs(a.astype(int) - b).mean() > 0.5  # the hand moved
        assert np.asarray(Image.open(io.BytesIO(frames.thumb(1)))).shape[1] == 128
    finally:
        frames.close()
    plots = session.plots(0)
    assert plots["frames"] == session.lengths[0] and len(plots["series"][0]["action"]) == plots["frames"]


def test_the_list_says_where_the_physics_blew_up_and_the_wearer_took_over(pose_recording, tmp_path):
    import json
    import shutil

    from recorder.review.session import Session

    src, _ = pose_recording
    copy = tmp_path / "blown"
    shutil.copytree(src, copy)
    sidecar = copy / "meta" / "gloverec" / "episodes.jsonl"
    lines = [json.loads(x) for x in sidecar.read_text().splitlines() if x.strip()]
    lines[1]["physics_unstable_s"] = 4.8  # as the recorder writes it when MuJoCo reset the simulation
    lines[2]["takeover"] = {"policy": "P", "frames_by_wearer": 52, "switches": [], "interventions": 1}
    sidecar.write_text("".join(json.dumps(x) + "\n" for x in lines))
    rows = Session(POSE_REPO, root=str(copy)).describe()["episodes"]
    assert [r["episode"] for r in rows if "physics blew up at 4.8 s" in (r["intent"] or "")] == [1]
    assert [r["episode"] for r in rows if "the wearer drove 52 frames" in (r["intent"] or "")] == [2]


@pytest.mark.process
def test_the_player_shows_a_camera_episode_decoded_from_its_video(tmp_path):
    from recorder.review.frames import Frames
    from recorder.review.session import Session

    root = tmp_path / "cam"
    r = gloverec("record", "--task", "pose", "--episodes", "2", "--episode-time-s", "1", "--cameras", "front",
                 "--root", str(root), "--repo-id", "test/cam", "--fast", "--no-log", "--json", timeout=120)  # fmt: skip
    assert r.returncode == 0, r.stderr
    session = Session("test/cam", root=str(root))
    frames = Frames(session)
    try:
        last = session.lengths[1] - 1
        image = np.asarray(Image.open(io.BytesIO(frames.frame(1, last))))
        assert image.shape == (128, 128, 3) and image.std() > 5  # the camera's frame, as recorded
        assert len(frames.decoded[1]) == session.lengths[1]  # the episode's segment, no more
    finally:
        frames.close()


def test_bad_edits_on_the_page_are_one_line_and_change_nothing(pose_recording, tmp_path):
    from recorder.review.session import Session

    src, _ = pose_recording
    out = tmp_path / "reviewed"
    session = Session(POSE_REPO, root=str(src), out=str(out))
    n = session.lengths[1]
    session.edit(1, "trim_end", 1.0)
    with pytest.raises(GloverecError, match="leaves nothing"):
        session.edit(1, "trim_start", 2.0)  # after the end kept
    assert session.pending == {1: {"trim": [0.0, 1.0]}}
    with pytest.raises(GloverecError, match="no episode 9"):
        session.edit(9, "discard")
    for e in range(4):
        session.edit(e, "discard")
    with pytest.raises(GloverecError, match="every episode is discarded"):
        session.publish()
    assert not out.exists()
    for e in range(4):
        session.edit(e, "keep")
    session.edit(1, "untrim")
    with pytest.raises(GloverecError, match="nothing to publish"):
        session.publish()
    assert session.lengths[1] == n and not out.exists()


def test_review_refuses_bad_input_in_one_line(pose_recording, tmp_path):
    src, _ = pose_recording
    r = cli("review", "--repo-id", "test/nothing", "--hub", str(tmp_path / "hub"), "--no-browser")
    assert r.returncode == 1 and len(r.stderr.strip().splitlines()) == 1, r.stderr
    damaged = tmp_path / "damaged"
    shutil.copytree(src, damaged)
    (damaged / "meta" / "info.json").unlink()
    (damaged / "meta" / "info.json").write_text("{")
    r = cli("review", "--repo-id", POSE_REPO, "--root", str(damaged), "--no-browser")
    assert r.returncode == 1 and len(r.stderr.strip().splitlines()) == 1 and "Traceback" not in r.stderr, r.stderr
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        r = cli("review", "--repo-id", POSE_REPO, "--root", str(src), "--http-port", str(port), "--no-browser")
    assert r.returncode == 1 and f"127.0.0.1:{port}" in r.stderr and "--http-port" in r.stderr, r.stderr
