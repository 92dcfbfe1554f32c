"""gloverec as a user installs it: wheels built from the checkout (gloverec and its LeRobot plugin), installed
without dependencies into a temporary target, recording with the emulated glove from another directory, with
only that target and the installed dependencies on the path: the checkout is not importable."""

import json
import os
import subprocess
import sys
import sysconfig
import zipfile
from pathlib import Path

import pytest

pytestmark = pytest.mark.process

ROOT = Path(__file__).resolve().parents[1]
PLUGINS = ("lerobot_policy_gloverec", "lerobot_teleoperator_gloverec", "lerobot_robot_gloverec")
PLUGIN_DIRS = [str(ROOT / p / "plugin") for p in ("policies", "recorder", "envs")]


@pytest.fixture(scope="module")
def installed(tmp_path_factory):
    base = tmp_path_factory.mktemp("wheel")
    wheels, target = base / "wheels", base / "site"
    pip = [sys.executable, "-m", "pip", "-q", "--disable-pip-version-check"]
    build = [*pip, "wheel", "--no-deps", "--no-build-isolation", "-w", str(wheels), str(ROOT), *PLUGIN_DIRS]
    r = subprocess.run(build, capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    found = sorted(wheels.glob("*.whl"))
    assert [w.name.split("-")[0] for w in found] == ["gloverec", *sorted(PLUGINS)]
    r = subprocess.run(
        [*pip, "install", "--no-deps", "--target", str(target), *map(str, found)],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert r.returncode == 0, r.stderr
    env = {k: v for k, v in os.environ.items() if not k.startswith("GLOVEREC_")}
    # -S: no site-packages .pth files, so the checkout's editable install is not on the path
    env["PYTHONPATH"] = os.pathsep.join([str(target), sysconfig.get_paths()["purelib"]])
    work = base / "work"
    work.mkdir()
    return {"wheel": found[0], "target": target, "env": env, "work": work}


def _run(installed, *args, timeout=300):
    cmd = [sys.executable, "-S", *args]
    return subprocess.run(
        cmd, capture_output=True, text=True, timeout=timeout, cwd=installed["work"], env=installed["env"]
    )


def test_the_wheel_ships_configs_and_models_and_no_data(installed):
    names = zipfile.ZipFile(installed["wheel"]).namelist()
    for shipped in (
        "recorder/configs/robots/shadow.yaml",
        "recorder/configs/fusion/madgwick.yaml",
        "recorder/configs/record/shadow_grasp.yaml",
        "envs/assets/glovehand/glovehand.xml",
    ):
        assert shipped in names
    assert not [n for n in names if n.startswith(("tests/", "datasets/", "bench/", "policies/plugin/"))]
    assert not [n for n in names if n.startswith(("recorder/plugin/", "envs/plugin/"))]


def test_the_installed_packages_come_from_the_target(installed):
    modules = ", ".join(("recorder", "envs", "policies", *PLUGINS))
    code = f"import sys, {modules}; print(*(m.__file__ for m in ({modules}))); print({str(ROOT)!r} in sys.path)"
    r = _run(installed, "-c", code)
    assert r.returncode == 0, r.stderr
    files, checkout_on_path = r.stdout.split("\n")[:2]
    assert all(f.startswith(str(installed["target"])) for f in files.split()), files
    assert checkout_on_path == "False"


def test_the_installed_command_records_and_publishes_under_the_working_directory(installed):
    gloverec = str(installed["target"] / "bin" / "gloverec")
    r = _run(installed, gloverec, "record", "--view", "none", "--episodes", "2", "--repo-id", "wheel/demo", "--json")
    assert r.returncode == 0, r.stderr
    summary = json.loads(r.stdout.strip().splitlines()[-1])
    assert summary["episodes_saved"] == 2 and summary["root"] == "datasets/recordings/wheel/demo"
    root = installed["work"] / summary["root"]
    r = _run(installed, gloverec, "push", "--repo-id", "wheel/demo", "--root", str(root), "--json")
    assert r.returncode == 0, r.stderr
    assert (installed["work"] / "datasets" / "hub" / "wheel" / "demo").exists()
    assert not list(installed["target"].glob("**/datasets")), "data written inside the installed package"
    code = (
        "from lerobot.datasets.lerobot_dataset import LeRobotDataset as D; "
        f"print(D('wheel/demo', root={str(root)!r}).num_episodes)"
    )
    assert _run(installed, "-c", code).stdout.strip() == "2"
