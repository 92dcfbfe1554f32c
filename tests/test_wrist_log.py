"""The wrist from a session log (issue 24, ``mcap:FILE``): `gloverec record --wrist` logs every tracker pose its
wrist fusion takes on /wrist/pose, `gloverec wrist --wrist mcap:LOG` plays them back, `gloverec rerecord`
re-records a free-wrist session from its log alone, and a file that is not such a log is one line."""

import json

import numpy as np
import pyarrow.parquet as pq
import pytest
from mcap.reader import make_reader

from conftest import cli, gloverec
from recorder.log import McapLogger, read_log
from recorder.log.writer import BYTES_TOPIC, WRIST_SCHEMA, WRIST_TOPIC
from recorder.wrist.log import read_wrist

EPISODE_S = 3.0


@pytest.fixture(scope="module")
def wrist_log(shared):
    """One relocate episode filmed by the emulated webcam (`--wrist marker:emulated`), recorded faster than real
    time once per run: (the dataset's root, its session log)."""

    def build(path):
        r = gloverec("record", "--task", "relocate", "--wrist", "marker:emulated", "--episodes", "1", "--fast",
                     "--episode-time-s", str(EPISODE_S), "--root", str(path / "ds"), "--repo-id", "test/wristlog",
                     "--json", timeout=120)  # fmt: skip
        assert r.returncode == 0, r.stderr
        (path / "summary.json").write_text(r.stdout.strip().splitlines()[-1])

    path = shared("wrist_log_recording", build)
    summary = json.loads((path / "summary.json").read_text())
    return path / "ds", path / "ds" / summary["log"]


def test_the_session_log_keeps_every_pose_the_wrist_fusion_took(wrist_log):
    _, log = wrist_log
    info = read_log(str(log))
    channel = info.channels[WRIST_TOPIC]
    assert channel["schema"] == "gloverec.WristPose" and channel["schema_encoding"] == "jsonschema"
    assert channel["metadata"]["source"] == "marker:emulated" and float(channel["metadata"]["latency_s"]) == 0.05
    _, poses = read_wrist(str(log))
    assert len(poses) == info.message_counts[WRIST_TOPIC] >= 0.8 * 30 * EPISODE_S  # a 30 Hz webcam
    t, taken = np.array([p.t for p, _ in poses]), np.array([k for _, k in poses])
    start = next(m["fields"]["glove_time_s"] for m in info.marks if m["name"] == "episode_start")
    assert np.all(np.diff(t) > 0) and np.all(taken >= t - 1e-9) and np.all(taken - t < 1 / 30 + 1e-6)
    assert start <= taken[0] and taken[-1] <= start + EPISODE_S  # on the glove's clock, within the episode
    assert np.mean([p.tracked for p, _ in poses]) > 0.9
    assert all(p.alternative is not None and len(p.errors_px) == 2 for p, _ in poses if p.tracked)
    with open(log, "rb") as f:  # what Foxglove reads: JSON with its schema, on the log's timeline
        wrist = list(make_reader(f).iter_messages(topics=[WRIST_TOPIC, BYTES_TOPIC], log_time_order=False))
    schema = next(s for s, c, _ in wrist if c.topic == WRIST_TOPIC)
    assert json.loads(schema.data) == WRIST_SCHEMA
    times = {topic: [m.log_time for _, c, m in wrist if c.topic == topic] for topic in (WRIST_TOPIC, BYTES_TOPIC)}
    assert times[WRIST_TOPIC] == sorted(times[WRIST_TOPIC]) and times[BYTES_TOPIC][0] < times[WRIST_TOPIC][0]
    assert all(set(json.loads(m.data)) == set(WRIST_SCHEMA["required"]) for _, c, m in wrist if c.topic == WRIST_TOPIC)


def test_gloverec_wrist_plays_the_log_s_poses_back(wrist_log):
    _, log = wrist_log
    _, poses = read_wrist(str(log))
    r = cli("wrist", "--wrist", f"mcap:{log}", "--fast", "--json")
    assert r.returncode == 0, r.stderr
    out = json.loads(r.stdout)
    assert out["poses"] == len(poses) and out["lost"] == 0 and abs(out["rate_hz"] - 30.0) < 0.5, out
    assert out["tracked_fraction"] == round(np.mean([p.tracked for p, _ in poses]), 4)
    assert np.allclose(out["position_m"], poses[-1][0].position, atol=1e-4)
    r = cli("wrist", "--wrist", f"mcap:{log}", "--duration", "0.5", "--json")  # in real time: a part of them
    out = json.loads(r.stdout)
    assert r.returncode == 0 and 0 < out["poses"] < len(poses), out
    assert 0 <= out["latency_ms_p50"] < 60  # the recorded age: capture to the frame tick that took the pose


@pytest.mark.process
def test_a_free_wrist_session_re_records_from_its_log_to_the_same_actions(wrist_log, tmp_path):
    root, log = wrist_log
    again = tmp_path / "again"
    r = gloverec("rerecord", "--log", str(log), "--repo-id", "test/again", "--root", str(again), "--json",
                 timeout=120)  # fmt: skip
    assert r.returncode == 0, r.stderr
    assert json.loads(r.stdout.strip().splitlines()[-1])["episodes_saved"] == 1
    a, b = pq.read_table(root / "data").to_pandas(), pq.read_table(again / "data").to_pandas()
    assert len(a) == len(b)
    for column in ("action", "observation.wrist", "observation.state"):
        np.testing.assert_allclose(np.stack(b[column]), np.stack(a[column]), atol=1e-6, err_msg=column)
    assert np.ptp(np.stack(a["action"])[:, -3:], axis=0).max() > 0.02  # the base moved: the wrist was replayed


def _not_mcap(path):
    path.write_text("seq,t,x\n1,0.0,0.3\n")


def _no_wrist(path):
    McapLogger(path, {"source": "emulator"}).close()


def _no_poses(path):
    with McapLogger(path, {"source": "emulator"}) as logger:
        logger.wrist_channel("udp:0.0.0.0:9100")


@pytest.mark.parametrize(
    ("make", "says"),
    [
        (None, "cannot read"),
        (_not_mcap, "is not an MCAP file"),
        (_no_wrist, "has no /wrist/pose channel: it was recorded without a tracker"),
        (_no_poses, "holds no wrist poses"),
    ],
)
def test_a_file_that_is_not_a_log_with_wrist_poses_is_one_line(tmp_path, make, says):
    path = tmp_path / "session.mcap"
    if make is not None:
        make(path)
    r = cli("wrist", "--wrist", f"mcap:{path}", "--fast")
    assert r.returncode == 1 and says in r.stderr and str(path) in r.stderr, r.stderr
    assert r.stderr.count("\n") == 1, r.stderr
