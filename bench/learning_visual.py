"""Learning from what a robot has: cameras, joint state and the instruction, no simulator state (bench/learning.py
measures the state-input policies).

    .venv/bin/python bench/learning_visual.py [--robots glovehand,shadow] [--demos 100] [--curve 10,25,50,100]
        [--steps 3000] [--batch-size 64] [--image-size 84] [--eval-episodes 50] [--workers 2] [--data DIR]
        [--parts main,blank,fist,pose,wrist,pick,curve,dexterous,act,diffusion,workers] [--dexterous keys] [--reuse]

For each robot, HandGrasp, with the gloverec commands a user runs (each in a child process):
  record DEMOS demonstrations with cameras front and top at SIZE x SIZE (emulated glove, scripted demonstrator,
      seeds 0..DEMOS-1; kept in --data to be reused)
  main   gloverec train (default inputs: state, images, task) -> gloverec eval, 50 unseen seeds, --perturb all
  blank  the same policy with its images blanked: --inputs state,task (no camera: what the joints and the
         instruction alone teach)
  fist   gloverec eval --policy fist (the open hand, a fist from the script's close phase on: what the scripted
         approach gives away)
  pose   HandPose, 50 demonstrations with the same cameras: default inputs, and without the instruction (the
         gesture to make is only in the instruction)
  wrist  HandGrasp with a free wrist (--wrist scripted: the policy places the hand, so only the cameras say
         where the object is): default inputs, and with the images blanked
  pick   HandPick (two objects, pick up the red or the blue one, a free wrist from a home pose), DEMOS
         demonstrations: default inputs, and blind: the images blanked (--inputs state,task: the robot's joints and
         palm and the instruction, no camera and no environment state, so where the named object lies is unknown)
  dexterous  each task of --dexterous (pinch, keys, turn), 50 demonstrations with the same cameras: default inputs,
         and with the images blanked (HandKeys: which key is lit is only in the scene)
  curve  images only (--inputs images), trained on the first K demonstrations, K in --curve
  act, diffusion  LeRobot's ACT and Diffusion Policy through lerobot-train on the same camera dataset without its
         environment state and glove (lerobot-edit-dataset remove_feature), no pretrained backbone, PyAV decoding
  workers  gloverec eval --workers 1 and --workers 2 of the main policy, episodes per second, same run
Success rates with Wilson 95 % intervals. Writes bench/results/learning_visual.json (rows of other robots or parts
already there are kept, each with when it was measured) and bench/results/learning_visual_curve.png.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import ACT_FLAGS, RESULTS, gloverec, merged_with_previous, wilson, write_results  # noqa: E402

os.environ.setdefault("MUJOCO_GL", "egl")
os.environ.setdefault("HF_HUB_OFFLINE", "1")

TASK = "grasp"
EVAL_SEED = 100_000
GOAL = 0.80  # images + state + instruction, from at most 100 demonstrations
MARGIN = 0.15  # above the blanked-image and fist baselines
DEXTEROUS_GOAL = 0.70  # each dexterous task, above its blanked-image policy
TRAIN_GOAL_S = 1800
CAMERAS = "front,top"
DEFAULT_INPUTS = "state,images,task"  # gloverec train's default: what a deployed robot has


def record(robot: str, demos: int, size: int, data: Path, task: str = TASK, wrist: bool = False) -> Path:
    """A camera dataset of ``demos`` demonstrations (seeds 0..demos-1), reused from ``data`` when there; ``wrist``:
    a free wrist, the demonstrator's reach in the action (--wrist scripted)."""
    root = data / f"{task}{'_wrist' if wrist else ''}_{robot}_{size}px_{demos}"
    if (root / "meta" / "info.json").is_file():
        print(f"  reusing {root}", flush=True)
        return root
    gloverec("record", "--view", "none", "--glove", "emulator", "--task", task, "--robot", robot, "--episodes",
             str(demos), "--cameras", CAMERAS, "--image-size", f"{size},{size}", "--root", str(root), "--repo-id",
             f"bench/{root.name}", "--seed", "0", "--fast", "--no-log", *(["--wrist", "scripted"] if wrist else []),
             timeout=7200)  # fmt: skip
    return root


def subset(root: Path, first: int) -> Path:
    """The first ``first`` episodes of ``root`` as their own dataset (gloverec edit --delete the rest)."""
    out = root.with_name(f"{root.name}_first{first}")
    if not (out / "meta" / "info.json").is_file():
        total = json.loads((root / "meta" / "info.json").read_text())["total_episodes"]
        gloverec("edit", "--repo-id", f"bench/{root.name}", "--root", str(root), "--out", str(out), "--delete",
                 f"{first}-{total - 1}", timeout=7200)  # fmt: skip
    return out


def train_eval(root: Path, out: Path, args, inputs: str | None, perturb: bool = False) -> dict:
    """Train (or, with --reuse, take the finished run in ``out``) and evaluate."""
    summary, config = out / "train_summary.json", out / "checkpoints" / "last" / "pretrained_model" / "config.json"
    if args.reuse and summary.is_file() and json.loads(summary.read_text())["steps"] == args.steps \
            and trained_as_default(json.loads(config.read_text())):  # fmt: skip
        print(f"  reusing the trained {out}", flush=True)
        trained = json.loads(summary.read_text())
        wall = trained["wall_s"]
    else:
        if out.exists():
            shutil.rmtree(out)
        flags = ["--inputs", inputs] if inputs else []
        t = time.perf_counter()
        trained = gloverec("train", "--repo-id", f"bench/{root.name}", "--root", str(root), "--steps",
                           str(args.steps), "--batch-size", str(args.batch_size), "--out", str(out), *flags,
                           timeout=4 * 3600)  # fmt: skip
        wall = time.perf_counter() - t
    ev = evaluate(str(out), None, args, perturb)
    return {
        "inputs": trained["inputs"],
        "train": {
            "image_shift": json.loads(config.read_text())["image_shift"],  # px: the DrQ augmentation
            "steps": args.steps,
            "batch_size": args.batch_size,
            "episodes": trained["train_episodes"],
            "frames": trained["train_frames"],
            "final_val_loss": trained["final_val_loss"],
            "wall_s": round(wall, 1),
            "goal_s": TRAIN_GOAL_S,
        },  # fmt: skip
        **ev,
    }


def with_twin(rows: dict, prefix: str, what: str, root: Path, run: Path, args, twin: str, suffix: str) -> None:
    """Rows "PREFIX/bc/INPUTS/WHAT" of a policy with the default inputs (trained in ``run``) and of its twin trained
    on ``twin`` inputs (in ``run``_``suffix``): the images blanked, or the instruction left out."""
    for inputs, out in ((DEFAULT_INPUTS, run), (twin, run.with_name(f"{run.name}_{suffix}"))):
        rows[f"{prefix}/bc/{inputs}/{what}"] = r = train_eval(
            root, out, args, None if inputs == DEFAULT_INPUTS else inputs
        )
        print(f"  {what}, BC {inputs.replace(',', '+')}: {r['success_rate']:.0%} {r['wilson95']}", flush=True)


def trained_as_default(config: dict) -> bool:
    """Whether a checkpoint's config.json has BC's default DrQ shift, or reads no camera (a run kept in --data is
    reused only then)."""
    from policies.bc.configuration_bc import BCConfig

    cameras = any(k.startswith("observation.images.") for k in config.get("input_features", {}))
    return not cameras or config["image_shift"] == BCConfig.image_shift


def evaluate(policy: str, robot: str | None, args, perturb: bool = False, workers: int | None = None,
             task: str = TASK) -> dict:  # fmt: skip
    extra = ["--task", task, "--robot", robot] if robot else []
    ev = gloverec("eval", "--policy", policy, *extra, "--episodes", str(args.eval_episodes), "--seed",
                  str(EVAL_SEED), "--workers", str(workers or args.workers),
                  *(["--perturb", "all"] if perturb else []), timeout=4 * 3600)  # fmt: skip
    row = {"episodes": ev["episodes"], "successes": ev["successes"], "success_rate": ev["success_rate"],
           "wilson95": wilson(ev["successes"], ev["episodes"]), "eval_wall_s": ev["wall_s"]}  # fmt: skip
    if "perturbed" in ev:
        row["perturbed"] = {
            k: {
                "successes": v["successes"],
                "success_rate": v["success_rate"],
                "wilson95": wilson(v["successes"], v["episodes"]),
            }  # fmt: skip
            for k, v in ev["perturbed"].items()
        }
    return row


# LeRobot's Diffusion Policy, small enough for this CPU: a ResNet-18 per camera trained from scratch (GroupNorm, as
# LeRobot requires without pretrained weights), a 64-128-256 UNet, DDPM with 10 inference steps
DIFFUSION_FLAGS = [
    "--policy.type=diffusion",
    "--policy.device=cpu",
    "--policy.push_to_hub=false",
    "--policy.pretrained_backbone_weights=null",
    "--policy.use_group_norm=true",
    "--policy.crop_shape=[76,76]",
    "--policy.down_dims=[64,128,256]",
    "--policy.n_obs_steps=2",
    "--policy.horizon=16",
    "--policy.n_action_steps=8",
    "--policy.drop_n_last_frames=7",
    "--policy.num_inference_steps=10",
    "--batch_size=32",
    "--num_workers=0",
    "--env_eval_freq=0",
    "--log_freq=200",
]
LEROBOT_FLAGS = {"act": [*ACT_FLAGS, "--policy.pretrained_backbone_weights=null"], "diffusion": DIFFUSION_FLAGS}


def robot_only(root: Path) -> Path:
    """The dataset without what a robot does not have (the environment state, the glove), for LeRobot's policies,
    which read every observation.* feature: lerobot-edit-dataset remove_feature, then our sidecar carried over."""
    import subprocess

    out = root.with_name(f"{root.name}_robot")
    if not (out / "meta" / "info.json").is_file():
        tool = str(Path(sys.executable).with_name("lerobot-edit-dataset"))
        subprocess.run([tool, f"--repo_id=bench/{root.name}", f"--root={root}", f"--new_repo_id=bench/{out.name}",
                        f"--new_root={out}", "--operation.type=remove_feature",
                        "--operation.feature_names=['observation.environment_state', 'observation.glove']"],
                       check=True, capture_output=True)  # fmt: skip
        # carry-meta prints no JSON (it has no --json), so not through gloverec()
        subprocess.run([sys.executable, "-m", "recorder.cli", "carry-meta", "--root", str(out), "--from", str(root)],
                       check=True, capture_output=True)  # fmt: skip
    return out


def lerobot_policy(kind: str, root: Path, out: Path, args) -> dict:
    """LeRobot's ACT or Diffusion Policy through lerobot-train on the camera dataset (state and images: neither
    reads the instruction), no ImageNet weights (nothing is downloaded), PyAV decoding; evaluated by gloverec."""
    import subprocess

    if out.exists():
        shutil.rmtree(out)
    data = robot_only(root)
    steps = args.act_steps if kind == "act" else args.diffusion_steps
    train = str(Path(sys.executable).with_name("lerobot-train"))
    cmd = [train, f"--dataset.repo_id=bench/{data.name}", f"--dataset.root={data}", "--dataset.video_backend=pyav",
           *LEROBOT_FLAGS[kind], f"--steps={steps}", f"--save_freq={steps}", f"--output_dir={out}"]  # fmt: skip
    print("  $ lerobot-train " + " ".join(cmd[1:]), flush=True)
    t = time.perf_counter()
    r = subprocess.run(cmd, capture_output=True, text=True, env={**os.environ, "OMP_NUM_THREADS": "1"})
    wall = time.perf_counter() - t
    if r.returncode != 0:
        return {"error": r.stderr.strip()[-1500:]}
    logged = [line for line in (r.stdout + r.stderr).splitlines() if " step:" in line and " loss:" in line]
    last = logged[-1].split(" step:")[1] if logged else None  # lerobot-train's last log line: step, loss, times
    return {"command": "lerobot-train " + " ".join(cmd[1:]), "steps": steps, "train_wall_s": round(wall, 1),
            "last_log": last, **evaluate(str(out), None, args)}  # fmt: skip


def workers_speed(policy: str, args) -> dict:
    """Episodes per second of the same evaluation in one process and in two (spawned) ones."""
    rows = {}
    for w in (1, 2):
        t = time.perf_counter()
        ev = gloverec("eval", "--policy", policy, "--episodes", str(args.eval_episodes), "--seed", str(EVAL_SEED),
                      "--workers", str(w), timeout=4 * 3600)  # fmt: skip
        rows[w] = {"command_wall_s": round(time.perf_counter() - t, 1), "runs": ev["runs"]}
    same = rows[1]["runs"] == rows[2]["runs"]
    eps = {w: args.eval_episodes / rows[w]["command_wall_s"] for w in rows}
    return {"episodes": args.eval_episodes, "wall_s": {w: rows[w]["command_wall_s"] for w in rows},
            "episodes_per_s": {w: round(v, 3) for w, v in eps.items()}, "speedup": round(eps[2] / eps[1], 2),
            "goal": 1.6, "same_per_seed_results": same}  # fmt: skip


def plot(curve: dict, path: Path, fist: dict | None = None) -> None:
    """Success against demonstrations per robot, with the fist baseline of each robot as a dashed line."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.5, 4), dpi=110)
    for robot, rows in sorted(curve.items()):
        ks = sorted(rows, key=int)
        rate = [rows[k]["success_rate"] for k in ks]
        low = [rows[k]["success_rate"] - rows[k]["wilson95"][0] for k in ks]
        high = [rows[k]["wilson95"][1] - rows[k]["success_rate"] for k in ks]
        line = ax.errorbar([int(k) for k in ks], rate, yerr=[low, high], marker="o", capsize=3, label=robot)
        if fist and robot in fist:
            ax.axhline(fist[robot], ls="--", color=line[0].get_color(), alpha=0.6, label=f"{robot}: fist baseline")
    ax.set_xscale("log")
    ax.set_xticks([10, 25, 50, 100], ["10", "25", "50", "100"])
    ax.set_ylim(0, 1.02)
    ax.set_xlabel("demonstrations")
    ax.set_ylabel(f"success, {TASK} (50 unseen seeds, Wilson 95 %)")
    ax.set_title("images only (front + top cameras), BC")
    ax.grid(True, alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--robots", default="glovehand,shadow")
    p.add_argument("--demos", type=int, default=100)
    p.add_argument("--curve", default="10,25,50,100", help="demonstrations for the images-only curve")
    p.add_argument("--steps", type=int, default=3000)
    p.add_argument("--batch-size", type=int, default=64)
    p.add_argument("--image-size", type=int, default=84)
    p.add_argument("--eval-episodes", type=int, default=50)
    p.add_argument("--workers", type=int, default=2, help="gloverec eval --workers")
    p.add_argument("--act-steps", type=int, default=1000)
    p.add_argument("--diffusion-steps", type=int, default=1000)
    p.add_argument("--data", default="bench/results/visual_data", help="recordings and runs, kept between runs")
    p.add_argument("--parts", default="main,blank,fist,pose,wrist,pick,curve,dexterous,act,diffusion,workers")
    p.add_argument("--dexterous", default="keys", help="tasks of the dexterous part")
    p.add_argument("--reuse", action="store_true", help="take training runs finished in --data (same steps)")
    args = p.parse_args()
    parts = set(args.parts.split(","))
    data = Path(args.data).absolute()
    data.mkdir(parents=True, exist_ok=True)
    rows, curve, extra = {}, {}, {}
    t0 = time.perf_counter()
    for robot in args.robots.split(","):
        print(f"[{TASK} on {robot}]", flush=True)
        grasp = parts & {"main", "blank", "fist", "curve", "act", "diffusion", "workers"}  # the parts on HandGrasp's
        root = record(robot, args.demos, args.image_size, data) if grasp else None
        key = f"{robot}/{args.demos}"
        if "main" in parts:
            rows[f"{key}/bc/state,images,task"] = r = train_eval(root, data / f"run_{robot}_main", args, None, True)
            print(f"  BC state+images+task: {r['success_rate']:.0%} {r['wilson95']}, perturbed {r['perturbed']}")
        if "blank" in parts:
            rows[f"{key}/bc/state,task"] = r = train_eval(root, data / f"run_{robot}_blank", args, "state,task")
            print(f"  BC state+task (images blanked): {r['success_rate']:.0%} {r['wilson95']}", flush=True)
        if "fist" in parts:
            rows[f"{robot}/-/fist/none"] = r = evaluate("fist", robot, args)
            print(f"  fist at the close phase: {r['success_rate']:.0%} {r['wilson95']}", flush=True)
        if "curve" in parts:
            for k in (int(x) for x in args.curve.split(",")):
                source = root if k == args.demos else subset(root, k)
                curve[f"{robot}/{k}"] = r = train_eval(source, data / f"run_{robot}_images_{k}", args, "images")
                print(f"  BC images only, {k} demonstrations: {r['success_rate']:.0%} {r['wilson95']}", flush=True)
        if "pose" in parts:  # the gesture is only in the instruction: what the embedding is for
            proot = record(robot, 50, args.image_size, data, task="pose")
            with_twin(rows, f"{robot}/50", "pose", proot, data / f"run_{robot}_pose", args, "state,images", "noinstr")
        if "dexterous" in parts:  # goal: each >= DEXTEROUS_GOAL and above its own blanked-image policy
            for task in args.dexterous.split(","):
                droot = record(robot, 50, args.image_size, data, task=task)
                with_twin(rows, f"{robot}/50", task, droot, data / f"run_{robot}_{task}", args, "state,task", "blank")
        if "wrist" in parts:  # the policy places the hand itself: where the object is, only the cameras tell
            wroot = record(robot, args.demos, args.image_size, data, wrist=True)
            with_twin(rows, key, "wrist", wroot, data / f"run_{robot}_wrist", args, "state,task", "blank")
        if "pick" in parts:  # two objects: the instruction's colour and the cameras say which to reach for and where
            kroot = record(robot, args.demos, args.image_size, data, task="pick")
            with_twin(rows, key, "pick", kroot, data / f"run_{robot}_pick", args, "state,task", "blank")
        for kind in ("act", "diffusion"):
            if kind in parts:
                rows[f"{key}/{kind}/state,images"] = r = lerobot_policy(kind, root, data / f"run_{robot}_{kind}", args)
                print(f"  {kind}: {r.get('success_rate', r)}", flush=True)
        if "workers" in parts and (data / f"run_{robot}_main").exists():
            extra[robot] = r = workers_speed(str(data / f"run_{robot}_main"), args)
            print(f"  eval --workers 2: {r['speedup']}x the episodes per second of --workers 1", flush=True)
    results = merged_with_previous(
        "learning_visual", {"rows": rows, "curve": curve, "workers": {k: v for k, v in extra.items()}}
    )
    by_robot: dict = {}
    for k, v in results["curve"].items():
        robot, demos = k.split("/")
        by_robot.setdefault(robot, {})[demos] = v
    if by_robot:
        fist = {k.split("/")[0]: v["success_rate"] for k, v in results["rows"].items() if k.endswith("/fist/none")}
        plot(by_robot, RESULTS / "learning_visual_curve.png", fist)
    write_results("learning_visual", {"task": TASK, "image_size": args.image_size, "cameras": CAMERAS,
                                      "eval_seeds_from": EVAL_SEED, "goal": GOAL, "margin": MARGIN,
                                      "dexterous_goal": DEXTEROUS_GOAL, **results,
                                      "wall_s": round(time.perf_counter() - t0, 1)})  # fmt: skip


if __name__ == "__main__":
    main()
