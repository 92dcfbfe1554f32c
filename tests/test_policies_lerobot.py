"""LeRobot's own tools on our data: `lerobot-train --policy.type=gloverec_bc` finds the policy through the
plugin distribution (policies/plugin, discovered by lerobot's register_third_party_plugins), and
`gloverec eval` runs the checkpoint lerobot-train wrote."""

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from test_policies import REPO, dataset, ok_json  # noqa: F401, F811  (the module-scoped recorded dataset)

pytestmark = pytest.mark.process

REPO_ROOT = Path(__file__).resolve().parents[1]
LEROBOT_TRAIN = Path(sys.executable).with_name("lerobot-train")


def _install_plugin(target: Path) -> None:
    """pip-install the plugin into a folder (not the venv): a real distribution named lerobot_policy_gloverec."""
    src = target.parent / "plugin-src"
    shutil.copytree(REPO_ROOT / "policies" / "plugin", src)
    r = subprocess.run(
        [
            sys.executable,
            "-m",
            "pip",
            "install",
            "-q",
            "--no-deps",
            "--no-build-isolation",
            "--target",
            str(target),
            str(src),
        ],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert r.returncode == 0, r.stderr[-2000:]
    assert (target / "lerobot_policy_gloverec").is_dir()


def test_lerobot_train_trains_gloverec_bc_through_the_plugin_and_gloverec_evaluates_it(dataset, tmp_path):  # noqa: F811
    plugin = tmp_path / "site"
    _install_plugin(plugin)
    out = tmp_path / "lerobot-run"
    env = {
        **os.environ,
        "PYTHONPATH": os.pathsep.join(filter(None, [str(plugin), os.environ.get("PYTHONPATH")])),
        "OMP_NUM_THREADS": "1",
        "HF_HUB_OFFLINE": "1",
    }
    r = subprocess.run(
        [
            str(LEROBOT_TRAIN),
            f"--dataset.repo_id={REPO}",
            f"--dataset.root={dataset}",
            "--policy.type=gloverec_bc",
            "--policy.device=cpu",
            "--policy.push_to_hub=false",
            "--policy.hidden_dim=64",
            "--steps=10",
            "--batch_size=16",
            f"--output_dir={out}",
            "--num_workers=0",
            "--save_freq=10",
            "--log_freq=5",
            "--env_eval_freq=0",
        ],
        capture_output=True,
        text=True,
        timeout=240,
        env=env,
        cwd=tmp_path,
    )
    assert r.returncode == 0, r.stderr[-3000:]
    model = out / "checkpoints" / "last" / "pretrained_model"
    assert json.loads((model / "config.json").read_text())["type"] == "gloverec_bc"
    assert (model / "policy_preprocessor.json").is_file()
    # no gloverec.json here: task, robot and rate come from lerobot's train_config.json -> the dataset
    result = ok_json("eval", "--policy", str(out), "--episodes", "1")
    assert (result["task"], result["robot"], result["policy_type"]) == ("pose", "glovehand", "gloverec_bc")
    assert 0.0 <= result["success_rate"] <= 1.0


@pytest.mark.xdist_group("lerobot.md")  # with the docs block it reads
def test_the_documented_two_process_launch_trains_on_two_processes(docs_run):
    """docs/lerobot.md's multi-process block, run as written (tests/test_docs.py: `accelerate launch --multi_gpu
    --num_processes=2 lerobot-train` for 50 steps on two recorded episodes, then `gloverec eval` of its checkpoint):
    two processes trained it, not one (`accelerate launch --cpu` runs one, silently)."""
    from docs_runner import ROOT, run_blocks_of

    blocks = run_blocks_of(ROOT / "docs" / "lerobot.md")
    index = next(k for k, b in enumerate(blocks) if "accelerate launch" in b.text)
    last = docs_run("lerobot.md", index) / "lr_bc_2proc" / "checkpoints" / "last"
    step = json.loads((last / "training_state" / "training_step.json").read_text())
    assert (step["num_processes"], step["batch_size"], step["step"]) == (2, 32, 50)
    assert json.loads((last / "pretrained_model" / "config.json").read_text())["type"] == "gloverec_bc"


def test_lerobot_plugin_discovery_is_what_registers_the_policy(tmp_path):
    """The control: in a fresh interpreter LeRobot does not know gloverec_bc until its plugin discovery
    (register_third_party_plugins, what lerobot-train runs first) imports the lerobot_policy_gloverec
    distribution."""
    plugin = tmp_path / "site"
    _install_plugin(plugin)
    code = (
        "import sys\n"
        "from lerobot.configs.policies import PreTrainedConfig\n"
        "from lerobot.utils.import_utils import register_third_party_plugins\n"
        "before = 'gloverec_bc' in PreTrainedConfig.get_known_choices()\n"
        "register_third_party_plugins()\n"
        "after = 'gloverec_bc' in PreTrainedConfig.get_known_choices()\n"
        "print(before, after, 'policies.bc' in sys.modules)\n"
    )
    env = {**os.environ, "PYTHONPATH": str(plugin), "HF_HUB_OFFLINE": "1"}
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120, env=env, cwd=tmp_path)
    assert r.returncode == 0, r.stderr[-2000:]
    assert r.stdout.split() == ["False", "True", "True"]


def test_lerobot_train_trains_act_on_a_gloverec_dataset_and_gloverec_evaluates_it(dataset, tmp_path):  # noqa: F811
    """docs/policies.md's ACT command (state-only ACT reads observation.environment_state), with a smaller model
    and fewer steps; gloverec eval finds the task and robot through lerobot's train_config.json."""
    out = tmp_path / "act"
    args = [
        f"--dataset.repo_id={REPO}", f"--dataset.root={dataset}", "--policy.type=act", "--policy.device=cpu",
        "--policy.push_to_hub=false", "--policy.dim_model=64", "--policy.dim_feedforward=128",
        "--policy.n_encoder_layers=1", "--policy.n_vae_encoder_layers=1", "--policy.chunk_size=10",
        "--policy.n_action_steps=1", "--policy.temporal_ensemble_coeff=0.01", "--policy.optimizer_lr=1e-4",
        "--steps=10", "--batch_size=16", f"--output_dir={out}", "--num_workers=0", "--env_eval_freq=0",
    ]  # fmt: skip
    env = {**os.environ, "OMP_NUM_THREADS": "1", "HF_HUB_OFFLINE": "1"}
    r = subprocess.run([str(LEROBOT_TRAIN), *args], capture_output=True, text=True, timeout=240, env=env, cwd=tmp_path)
    assert r.returncode == 0, r.stderr[-3000:]
    model = out / "checkpoints" / "last" / "pretrained_model"
    assert json.loads((model / "config.json").read_text())["type"] == "act"
    result = ok_json("eval", "--policy", str(out), "--episodes", "1")
    assert (result["task"], result["robot"], result["policy_type"]) == ("pose", "glovehand", "act")
    assert result["episode_lengths"] and 0.0 <= result["success_rate"] <= 1.0
