"""The local hub: push, versions, verify, pull, atomicity and one-line errors, on real (tiny) LeRobot datasets."""

import argparse
import hashlib
import json
import os
import shutil
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pytest

from recorder import GloverecError
from recorder.hub import atomic
from recorder.hub.cli import add_parsers
from recorder.hub.manifest import NAME as MANIFEST
from recorder.hub.store import Hub

REPO = "alice/grasp"
DATA = "data/chunk-000/file-000.parquet"
FEATURES = {
    "observation.state": {"dtype": "float32", "shape": (3,), "names": None},
    "action": {"dtype": "float32", "shape": (2,), "names": None},
}


def make_dataset(root: Path, episodes: int, seed: int) -> Path:
    """A small dataset written with lerobot's own API."""
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    rng = np.random.default_rng(seed)
    ds = LeRobotDataset.create(REPO, 10, FEATURES, root=root, use_videos=False)
    for e in range(episodes):
        for _ in range(4 + e):
            ds.add_frame(
                {
                    "observation.state": rng.normal(size=3).astype(np.float32),
                    "action": rng.normal(size=2).astype(np.float32),
                    "task": f"grasp {e % 2}",
                }
            )
        ds.save_episode()
    ds.finalize()
    return root


def rows(root) -> list[tuple]:
    """Every frame of the dataset at ``root`` as loaded by LeRobotDataset, as comparable tuples."""
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    ds = LeRobotDataset(REPO, root=root)
    return [
        (
            tuple(f["observation.state"].tolist()),
            tuple(f["action"].tolist()),
            int(f["episode_index"]),
            int(f["index"]),
            round(float(f["timestamp"]), 6),
            f["task"],
        )
        for f in (ds[i] for i in range(len(ds)))
    ]


@pytest.fixture(scope="module")
def sources(tmp_path_factory):
    """Two versions of one dataset (2 and 3 episodes) and what lerobot loads from each. Read-only for tests."""
    base = tmp_path_factory.mktemp("src")
    a, b = make_dataset(base / "a", 2, seed=1), make_dataset(base / "b", 3, seed=2)
    return {"a": a, "b": b, "rows_a": rows(a), "rows_b": rows(b)}


@pytest.fixture
def hub(tmp_path) -> Hub:
    return Hub(tmp_path / "hub")


def cli(*argv: str) -> int:
    """Run a command through the parsers ``add_parsers`` makes, as `gloverec` will."""
    parser = argparse.ArgumentParser(prog="gloverec")
    add_parsers(parser.add_subparsers(dest="command", required=True))
    args = parser.parse_args(argv)
    return args.func(args)


def one_line_error(fn, *args, needle: str) -> str:
    with pytest.raises(GloverecError) as info:
        fn(*args)
    text = str(info.value)
    assert "\n" not in text and needle in text, text
    return text


def flip_byte(path: Path, offset: int | None = None) -> None:
    os.chmod(path, 0o644)
    data = bytearray(path.read_bytes())
    data[len(data) // 2 if offset is None else offset] ^= 0x01
    path.write_bytes(bytes(data))


# ------------------------------------------------------------------ push and load


def test_push_publishes_a_version_lerobot_loads(hub, sources, capsys):
    assert cli("push", "--repo-id", REPO, "--root", str(sources["a"]), "--hub", str(hub.root), "--json") == 0
    out = json.loads(capsys.readouterr().out)
    assert out["version"] == "v1" and out["episodes"] == 2 and out["frames"] == 9 and out["same_as"] is None
    link = hub.root / REPO
    assert link.is_symlink() and os.readlink(link) == "grasp@v1"
    assert rows(link) == sources["rows_a"]
    manifest = json.loads((link / MANIFEST).read_text())
    assert manifest["repo_id"] == REPO and manifest["version"] == "v1"
    assert sorted(manifest["files"]) == sorted(
        p.relative_to(sources["a"]).as_posix() for p in sources["a"].rglob("*") if p.is_file()
    )
    for rel, entry in manifest["files"].items():
        assert entry["sha256"] == hashlib.sha256((sources["a"] / rel).read_bytes()).hexdigest()
        assert not os.stat(link / rel).st_mode & 0o222  # published files are read-only
    (hub.root / "plain").mkdir()  # folders get the usual permissions (umask), so a shared hub is readable
    assert os.stat(link).st_mode == os.stat(hub.root / "plain").st_mode == os.stat(link / "meta").st_mode


def test_push_skips_scratch_files(hub, sources, tmp_path):
    src = tmp_path / "src"
    shutil.copytree(sources["a"], src)
    for junk in ("images/observation.images.cam/episode-000000/frame-000000.png", ".cache/huggingface/x.lock"):
        (src / junk).parent.mkdir(parents=True)
        (src / junk).write_bytes(b"scratch")
    v = hub.push(src, REPO)
    assert sorted(v.manifest()["files"]) == sorted(
        p.relative_to(sources["a"]).as_posix() for p in sources["a"].rglob("*") if p.is_file()
    )
    assert not (v.path / "images").exists() and not (v.path / ".cache").exists() and hub.verify().ok


def test_push_refuses_a_folder_holding_another_dataset_and_publishes_nothing(hub, sources, tmp_path):
    """What lerobot-edit-dataset 0.4.4's --new_repo_id without --new_root did to a recording (issue 26): the next
    push would have published the edited dataset as part of the original's next version, without a word."""
    src = tmp_path / "src"
    shutil.copytree(sources["a"], src)
    shutil.copytree(sources["b"], src / "me" / "grasp_cut")
    one_line_error(hub.push, src, REPO, needle="holds another dataset inside it (me/grasp_cut/)")
    assert hub.versions(REPO) == []


def test_repush_makes_v2_and_v1_stays_loadable(hub, sources, capsys):
    assert hub.push(sources["a"], REPO).tag == "v1"
    assert rows(hub.root / REPO) == sources["rows_a"]
    assert hub.push(sources["b"], REPO).tag == "v2"
    assert hub.push(sources["b"], REPO).tag == "v3"  # same content: still a new version, flagged as a twin
    assert hub.twin(hub.version(REPO, "v3")).tag == "v2" and hub.twin(hub.version(REPO, "v2")) is None
    assert rows(hub.root / REPO) == sources["rows_b"]
    assert rows(hub.root / "alice/grasp@v1") == sources["rows_a"]
    cli("hub", "list", "--hub", str(hub.root), "--json")
    [entry] = json.loads(capsys.readouterr().out)
    assert entry["repo_id"] == REPO and entry["latest"] == "v3"
    assert [v["version"] for v in entry["versions"]] == ["v1", "v2", "v3"]
    assert [v["episodes"] for v in entry["versions"]] == [2, 3, 3]
    cli("hub", "list", "--hub", str(hub.root))
    text = capsys.readouterr().out
    assert "alice/grasp  latest v3  (3 versions)" in text and "  v1  " in text


def test_hub_location_comes_from_flag_env_or_default(tmp_path, sources, monkeypatch):
    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv("GLOVEREC_HUB", raising=False)
    cli("push", "--repo-id", REPO, "--root", str(sources["a"]))
    assert (tmp_path / "datasets/hub/alice/grasp@v1" / MANIFEST).is_file()
    monkeypatch.setenv("GLOVEREC_HUB", str(tmp_path / "env-hub"))
    cli("push", "--repo-id", REPO, "--root", str(sources["a"]))
    assert (tmp_path / "env-hub/alice/grasp@v1").is_dir()
    cli("push", "--repo-id", REPO, "--root", str(sources["a"]), "--hub", str(tmp_path / "flag-hub"))
    assert (tmp_path / "flag-hub/alice/grasp@v1").is_dir()
    assert not (tmp_path / "datasets/hub/alice/grasp@v2").exists()


# ------------------------------------------------------------------ verify


def test_verify_catches_one_flipped_byte_in_any_file(hub, sources, capsys):
    v = hub.push(sources["a"], REPO)
    assert cli("hub", "verify", "--hub", str(hub.root)) == 0
    files = sorted(json.loads((v.path / MANIFEST).read_text())["files"])
    assert DATA in files and len(files) == 5
    for rel in files:
        for offset in (0, None, -1):  # first, middle and last byte
            flip_byte(v.path / rel, offset)
            text = one_line_error(cli, "hub", "verify", "--hub", str(hub.root), needle=f"altered {rel}")
            assert "alice/grasp v1" in text
            flip_byte(v.path / rel, offset)
            assert hub.verify().ok
    flip_byte(v.path / DATA)
    capsys.readouterr()
    with pytest.raises(GloverecError):
        cli("hub", "verify", "--repo-id", REPO, "--version", "v1", "--hub", str(hub.root), "--json")
    report = json.loads(capsys.readouterr().out)
    assert report["ok"] is False and report["versions"][0]["altered"] == [DATA]


def test_verify_names_missing_and_unexpected_files(hub, sources, capsys):
    v1, v2 = hub.push(sources["a"], REPO), hub.push(sources["b"], REPO)
    (v2.path / "meta/stats.json").unlink()
    (v2.path / "data/notes.txt").write_text("hello")
    text = one_line_error(cli, "hub", "verify", "--hub", str(hub.root), needle="missing meta/stats.json")
    assert "unexpected data/notes.txt" in text and "alice/grasp v1" not in text  # only v2 is damaged
    printed = capsys.readouterr().out
    assert "ok       alice/grasp v1" in printed and "DAMAGED  alice/grasp v2" in printed
    assert cli("hub", "verify", "--repo-id", REPO, "--version", "v1", "--hub", str(hub.root)) == 0
    (v1.path / MANIFEST).unlink()
    one_line_error(hub.version(REPO, "v1").manifest, needle=f"no {MANIFEST}")
    one_line_error(
        cli,
        "hub",
        "verify",
        "--repo-id",
        REPO,
        "--version",
        "1",
        "--hub",
        str(hub.root),
        needle=f"alice/grasp v1 ({v1.path} is damaged: no {MANIFEST})",
    )
    cli("hub", "list", "--hub", str(hub.root))
    assert "v1  damaged:" in capsys.readouterr().out


# ------------------------------------------------------------------ bad input


@pytest.mark.parametrize(
    "repo_id",
    [
        "noslash",
        "a/b/c",
        "../x",
        "a/..",
        "/abs/x",
        "a/",
        "/b",
        "",
        "a b/c",
        "a/b@v1",
        ".hidden/x",
        "a/b..c",
        "a/.b",
        "a/" + "x" * 97,
        "é/x",
        "a\\b/c",
    ],
)
def test_bad_repo_ids_are_one_line_errors(hub, sources, repo_id):
    one_line_error(hub.push, sources["a"], repo_id, needle="bad repo id")
    assert not hub.root.exists()  # nothing written


def _damaged_copies(base: Path, src: Path):
    """Folders that are not datasets or are damaged ones, each with the words its error must contain."""
    yield base / "nowhere", "is not a directory"
    (base / "empty").mkdir()
    yield base / "empty", "no meta/info.json"

    def copy(name, edit):
        shutil.copytree(src, base / name)
        edit(base / name)
        return base / name

    def cut_footer(root):
        path = root / DATA
        path.write_bytes(path.read_bytes()[:-20])

    def info_edit(**changes):
        def edit(root):
            info = json.loads((root / "meta/info.json").read_text())
            (root / "meta/info.json").write_text(json.dumps({**info, **changes}))

        return edit

    yield copy("nofooter", cut_footer), f"{DATA} is not a readable parquet file"
    yield copy("frames", info_edit(total_frames=99)), "says 99"
    yield copy("episodes", info_edit(total_episodes=5)), "episodes 0..4"
    yield copy("old", info_edit(codebase_version="v2.1")), "'v2.1' dataset"
    yield copy("badjson", lambda r: (r / "meta/info.json").write_text("{not json")), "cannot read meta/info.json"
    yield copy("nodata", lambda r: (r / DATA).unlink()), "data/ holds 0 frames"
    yield copy("notasks", lambda r: (r / "meta/tasks.parquet").unlink()), "no meta/tasks.parquet"


def test_bad_roots_are_one_line_errors_and_publish_nothing(hub, sources, tmp_path):
    cases = list(_damaged_copies(tmp_path, sources["a"]))
    for root, needle in cases:
        assert one_line_error(hub.push, root, REPO, needle=needle).startswith(f"{root} ")
        assert hub.versions(REPO) == []
        assert not any(atomic.is_temp(p.name) for p in (hub.root / "alice").glob("*")), root
    one_line_error(Hub(sources["a"] / "hub").push, sources["a"], REPO, needle="is inside the dataset")
    (tmp_path / "afile").write_text("")
    one_line_error(Hub(tmp_path / "afile").push, sources["a"], REPO, needle="cannot push to")


def test_bad_versions_and_unknown_datasets_are_one_line_errors(hub, sources, tmp_path):
    one_line_error(hub.verify, needle="no hub at")
    hub.push(sources["a"], REPO)
    one_line_error(hub.version, REPO, "v9", needle="has no version v9 in")
    one_line_error(hub.version, "bob/other", None, needle="no dataset bob/other")
    for bad in ("vx", "v0", "-1", "v1.0", ""):
        one_line_error(hub.version, REPO, bad, needle="bad version")
    one_line_error(
        cli,
        "hub",
        "pull",
        "--repo-id",
        REPO,
        "--version",
        "v2",
        "--root",
        str(tmp_path / "o"),
        "--hub",
        str(hub.root),
        needle="(it has v1)",
    )
    one_line_error(cli, "hub", "verify", "--version", "v1", "--hub", str(hub.root), needle="needs --repo-id")
    assert not (tmp_path / "o").exists()


def test_usage_errors_exit_2(capsys):
    for argv in (["push", "--root", "x"], ["hub"], ["hub", "pull", "--repo-id", REPO], ["hub", "frob"]):
        with pytest.raises(SystemExit) as info:
            cli(*argv)
        assert info.value.code == 2
    capsys.readouterr()


def test_to_hf_fails_in_one_line_when_offline_before_writing(hub, sources, monkeypatch, tmp_path):
    args = ("push", "--repo-id", REPO, "--root", str(sources["a"]), "--hub", str(hub.root), "--to-hf")
    monkeypatch.setenv("HF_HUB_OFFLINE", "1")
    one_line_error(cli, *args, needle="HF_HUB_OFFLINE is set")
    import huggingface_hub.constants

    monkeypatch.setenv("HF_HUB_OFFLINE", "0")
    monkeypatch.delenv("HF_TOKEN", raising=False)
    monkeypatch.delenv("HUGGING_FACE_HUB_TOKEN", raising=False)
    monkeypatch.setattr(huggingface_hub.constants, "HF_TOKEN_PATH", str(tmp_path / "no-token"))
    one_line_error(cli, *args, needle="no Hugging Face token")
    assert not hub.root.exists()


# ------------------------------------------------------------------ atomicity and concurrency

KILLER = """
import os, signal, sys
from recorder.hub import atomic, manifest, store

hub, src, repo, moment = sys.argv[1:]
def die(*_, **__):
    os.kill(os.getpid(), signal.SIGKILL)
if moment == "copying":  # after two files
    real, seen = manifest._hash_one, []
    def hash_one(*a):
        seen.append(a)
        if len(seen) == 3:
            die()
        return real(*a)
    manifest._hash_one = hash_one
elif moment == "publishing":  # all copied, checked and sealed; the rename never happens
    store.os.rename = die
else:  # "linking": the version is published, the latest link not yet switched
    atomic.point_link = die
store.Hub(hub).push(src, repo)
"""


@pytest.mark.process
@pytest.mark.parametrize("moment", ["copying", "publishing", "linking"])
def test_killed_push_leaves_no_partial_version(hub, sources, moment, capsys):
    hub.push(sources["a"], REPO)
    r = subprocess.run(
        [sys.executable, "-c", KILLER, str(hub.root), str(sources["b"]), REPO, moment],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert r.returncode == -9, r.stderr
    leftovers = [p.name for p in (hub.root / "alice").iterdir() if atomic.is_temp(p.name)]
    cli("hub", "list", "--hub", str(hub.root), "--json")
    [entry] = json.loads(capsys.readouterr().out)
    assert entry["latest"] == "v1"
    assert rows(hub.root / REPO) == sources["rows_a"]  # readers still get the complete v1
    if moment == "linking":  # v2 is complete and listed; verify repairs the link
        assert leftovers == [] and [v["version"] for v in entry["versions"]] == ["v1", "v2"]
        report = hub.verify()
        assert report.ok and report.relinked == [f"{REPO} -> v2"]
        assert rows(hub.root / REPO) == sources["rows_b"]
    else:  # only a staging folder, invisible to list and load; verify removes it
        assert len(leftovers) == 1 and [v["version"] for v in entry["versions"]] == ["v1"]
        report = hub.verify()
        assert report.ok and report.cleaned == [f"alice/{leftovers[0]}"] and report.relinked == []
        assert hub.push(sources["b"], REPO).tag == "v2"
    assert not any(atomic.is_temp(p.name) for p in (hub.root / "alice").iterdir())


@pytest.mark.process
def test_next_push_cleans_stale_staging_but_not_a_live_one(hub, sources):
    hub.push(sources["a"], REPO)
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True)
    stale = hub.root / "alice" / f".tmp-{int(dead.stdout)}-grasp-0000"
    live = atomic.temp_dir(hub.root / "alice", "grasp")  # this process: a push in progress
    (stale / "data").mkdir(parents=True)
    hub.push(sources["b"], REPO)
    assert not stale.exists() and live.exists()
    assert hub.repo_ids() == [REPO] and [v.tag for v in hub.versions(REPO)] == ["v1", "v2"]


def test_racing_pushes_never_share_a_number(hub, sources, monkeypatch):
    monkeypatch.setattr(Hub, "_next_number", lambda self, repo_id: 1)  # every push believes v1 is free
    assert [hub.push(sources["a"], REPO).tag for _ in range(3)] == ["v1", "v2", "v3"]
    monkeypatch.undo()
    with ThreadPoolExecutor(4) as pool:
        tags = list(pool.map(lambda src: Hub(hub.root).push(src, REPO).tag, [sources["a"], sources["b"]] * 3))
    assert sorted(tags, key=lambda t: int(t[1:])) == [f"v{n}" for n in range(4, 10)]
    assert hub.latest(REPO) == "v9" and hub.verify().ok
    for v in hub.versions(REPO):
        assert v.manifest()["version"] == v.tag


def test_a_relink_from_a_stale_view_corrects_itself(hub, sources, monkeypatch):
    hub.push(sources["a"], REPO)
    hub.push(sources["a"], REPO)
    real, calls = Hub.versions, []

    def stale_first(self, repo_id):  # the first look predates v2's rename, as for a slow concurrent push
        calls.append(repo_id)
        return real(self, repo_id)[:1] if len(calls) == 1 else real(self, repo_id)

    monkeypatch.setattr(Hub, "versions", stale_first)
    assert hub.relink(REPO) == "v2" and hub.latest(REPO) == "v2" and len(calls) > 2


def test_push_replaces_the_empty_folder_a_premature_load_leaves(hub, sources):
    (hub.root / REPO / "meta").mkdir(parents=True)  # what LeRobotDataset(root=hub/REPO) leaves when offline
    hub.push(sources["a"], REPO)
    assert (hub.root / REPO).is_symlink()
    hub.root.joinpath("bob/x").mkdir(parents=True)
    hub.root.joinpath("bob/x/mine.txt").write_text("a user's file")
    one_line_error(hub.push, sources["a"], "bob/x", needle="move it away")
    assert hub.versions("bob/x") == [] and hub.root.joinpath("bob/x/mine.txt").is_file()


# ------------------------------------------------------------------ pull


def test_pull_copies_a_verified_version_that_loads(hub, sources, tmp_path, capsys):
    hub.push(sources["a"], REPO)
    hub.push(sources["b"], REPO)
    out = tmp_path / "pulled" / "v1"
    assert (
        cli("hub", "pull", "--repo-id", REPO, "--version", "v1", "--root", str(out), "--hub", str(hub.root), "--json")
        == 0
    )
    assert json.loads(capsys.readouterr().out)["version"] == "v1"
    assert rows(out) == sources["rows_a"]
    assert not (out / MANIFEST).exists() and os.access(out / DATA, os.W_OK)  # a plain, writable dataset
    (tmp_path / "empty").mkdir()
    hub.pull(REPO, None, tmp_path / "empty")  # the newest, into an empty folder
    assert rows(tmp_path / "empty") == sources["rows_b"]
    one_line_error(hub.pull, REPO, None, out, needle="already exists")
    one_line_error(
        cli,
        "hub",
        "pull",
        "--repo-id",
        REPO,
        "--root",
        str(out / DATA / "x"),
        "--hub",
        str(hub.root),
        needle="cannot pull into",
    )
    one_line_error(hub.pull, REPO, None, hub.root / "alice/copy", needle="overlaps the hub")
    flip_byte(hub.version(REPO, "v2").path / DATA)
    one_line_error(hub.pull, REPO, "v2", tmp_path / "bad", needle=f"damaged (altered {DATA})")
    assert not (tmp_path / "bad").exists() and not any(atomic.is_temp(p.name) for p in tmp_path.iterdir())
