"""Demonstrations with recoveries (`gloverec record --dart SCALE`, recorder/record/dart.py): the executed action is the
wearer's plus seeded, temporally correlated noise; `action` stores what was executed, `expert.action` and
`expert.offset` what the wearer meant and what was added; `gloverec train --learn-from intended` learns the intended
action chunks."""

from __future__ import annotations

import json

import numpy as np
import pytest
from docs_runner import ROOT, run_blocks_of

from conftest import cli, gloverec
from recorder.record.dart import EXPERT_ACTION, EXPERT_OFFSET, Dart

REPO = "me/pose_dart"


def _documented_block() -> int:
    return next(k for k, b in enumerate(run_blocks_of(ROOT / "docs" / "recording.md")) if "--dart" in b.text)


def _recording(docs_run):
    """The documented DART block's folder (a recording, its replay, a training on the intended actions)."""
    return docs_run("recording.md", _documented_block())


def _columns(root, repo_id: str = REPO) -> dict[str, np.ndarray]:
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    data = LeRobotDataset(repo_id, root=root).hf_dataset.with_format("numpy")
    return {
        k: np.stack(data[k]) for k in ("episode_index", "observation.state", "action", EXPERT_ACTION, EXPERT_OFFSET)
    }


def test_the_noise_holds_over_frames_scales_with_each_range_and_follows_the_episode_seed():
    low, high = np.array([0.0, -1.0, 0.2]), np.array([1.0, 1.0, 0.7])

    def draw(dart: Dart, seed: int, n: int = 3000) -> np.ndarray:
        dart.reset(seed)
        return np.array([dart.perturb(np.zeros(3)) for _ in range(n)], float)

    dart = Dart(0.1, 0.2, low, high, fps=30)
    noise = draw(dart, 7)
    assert np.array_equal(noise, draw(dart, 7)) and not np.allclose(noise[:100], draw(dart, 8)[:100])
    assert np.allclose(noise[300:].std(axis=0), 0.1 * (high - low), rtol=0.25)  # a share of each element's range
    lag1 = [np.corrcoef(x[:-1, 0], x[1:, 0])[0, 1] for x in (noise, draw(Dart(0.1, 0.0, low, high, 30), 7))]
    assert lag1[0] > 0.75 and abs(lag1[1]) < 0.1  # held over 0.2 s (exp(-1/6) = 0.85 a frame); 0 s: white


def test_a_dart_recording_replays_exactly_and_its_noise_is_the_executed_less_the_intended(docs_run):
    """The documented recording: every episode replays exactly from its stored actions, the stored noise is exactly
    action - intended in float32 and not zero, executing the intended actions instead leads elsewhere (the noise
    moved the hand), and LeRobot takes neither feature for a policy input or the action."""
    from lerobot.datasets.lerobot_dataset import LeRobotDatasetMetadata
    from lerobot.utils.feature_utils import dataset_to_policy_features

    import envs
    from policies.data import resolve
    from policies.replay import replay
    from recorder.record.sidecar import read_sidecar

    root = _recording(docs_run) / "pose_dart"
    c = _columns(root)
    assert c[EXPERT_OFFSET].dtype == c["action"].dtype == c[EXPERT_ACTION].dtype == np.float32
    assert np.array_equal(c["action"] - c[EXPERT_ACTION], c[EXPERT_OFFSET])
    assert (c[EXPERT_OFFSET] != 0).mean() > 0.9 and np.abs(c[EXPERT_OFFSET]).max() > 0.01
    records = read_sidecar(root)
    assert [r["dart"] for r in records] == [{"scale": 0.02, "time_s": 0.2}] * len(records) and len(records) == 2
    ref = resolve(REPO, root=root)
    for r in records:
        out = replay(ref, r["episode_index"])
        assert out["reproduced"] and out["max_abs"] == 0.0, out["first_divergent_step"]
    env = envs.make("pose", "glovehand")  # the same episode with the wearer's actions: the noise is what differs
    obs, _ = env.reset(seed=records[0]["seed"])
    rows = np.flatnonzero(c["episode_index"] == 0)
    apart = 0.0
    for i in rows:
        apart = max(apart, float(np.abs(obs["observation.state"] - c["observation.state"][i]).max()))
        obs, *_ = env.step(c[EXPERT_ACTION][i])
    assert apart > 0.01, apart
    features = dataset_to_policy_features(LeRobotDatasetMetadata(REPO, root=root).features)
    assert not [k for k in features if k.startswith("dart.")] and "action" in features


def test_training_on_the_intended_action_learns_its_chunks_and_statistics(docs_run):
    """The documented training ran (--learn-from intended); its frame cache holds the intended action's chunks, padded
    past each episode's end like the action's, in place of the action, and the statistics are theirs."""
    import torch

    from policies.data import FrameCache, resolve

    work = _recording(docs_run)
    summary = json.loads((work / "bc_dart" / "train_summary.json").read_text())
    assert summary["learn_from"] == "intended" and summary["train_frames"] > 0
    assert json.loads((work / "bc_dart" / "split.json").read_text())["learn_from"] == "intended"
    root = work / "pose_dart"
    c = _columns(root)
    delta = {"action": [k / 30 for k in range(3)]}
    cache = FrameCache(resolve(REPO, root=root), [0, 1], ["observation.state", "action"], delta, False, EXPERT_ACTION)
    assert set(cache.data) == {"observation.state", "action", "action_is_pad"}
    chunks, pad = cache.data["action"].numpy(), cache.data["action_is_pad"].numpy()
    for i in range(len(chunks)):
        for k in range(3):
            j = i + k
            inside = j < len(chunks) and c["episode_index"][j] == c["episode_index"][i]
            assert pad[i, k] == (not inside)
            if inside:
                assert np.array_equal(chunks[i, k], c[EXPERT_ACTION][j])
    stats = cache.stats(["action"], {})["action"]
    assert np.allclose(stats["mean"], c[EXPERT_ACTION].astype(np.float64).mean(axis=0))
    assert not torch.equal(cache.data["action"][:, 0], torch.from_numpy(c["action"]))


@pytest.mark.process
def test_rerecording_a_dart_session_draws_the_same_noise(docs_run, tmp_path):
    """The session log keeps the setting and the episode seeds seed the noise: `gloverec rerecord` reproduces it."""
    root = _recording(docs_run) / "pose_dart"
    log = next((root / "logs").glob("session-*.mcap"))
    r = gloverec("rerecord", "--log", str(log), "--repo-id", "me/again", "--root", str(tmp_path / "again"), "--json",
                 timeout=240)  # fmt: skip
    assert r.returncode == 0, r.stderr
    a, b = _columns(root), _columns(tmp_path / "again", "me/again")
    assert len(a["action"]) == len(b["action"])
    for key in ("action", EXPERT_OFFSET, EXPERT_ACTION):
        assert np.allclose(a[key], b[key], atol=1e-6), key


@pytest.mark.parametrize(
    "args, code, said",
    [
        (["--dart", "-0.1"], 2, "--dart: must be zero or more"),
        (["--dart", "1.5"], 1, "--dart 1.5: expected a share of the action's range below 1"),
        (["--dart", "0.05", "--policy", "."], 1, "--dart perturbs the wearer's demonstrations"),
    ],
)
def test_bad_dart_settings_are_one_line_and_write_nothing(tmp_path, args, code, said):
    r = cli("record", "--episodes", "1", "--root", str(tmp_path / "ds"), *args)
    assert r.returncode == code and r.stderr.strip().count("\n") == 0 and said in r.stderr, r.stderr
    assert not (tmp_path / "ds").exists()


def test_learning_the_intended_action_with_no_dataset_that_holds_it_is_one_line(pose_recording, tmp_path):
    root, _ = pose_recording
    r = cli("train", "--repo-id", "test/pose", "--root", str(root), "--learn-from", "intended", "--out",
            str(tmp_path / "out"), "--steps", "1")  # fmt: skip
    assert r.returncode == 1 and r.stderr.strip().count("\n") == 0, r.stderr
    assert "--learn-from intended: no dataset has expert.action" in r.stderr
    assert not (tmp_path / "out").exists()
