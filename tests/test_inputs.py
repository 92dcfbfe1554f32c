"""Inputs by name (policies/inputs.py): what a policy reads, and the task's values a LeRobot-layout dataset keeps
inside observation.state left out unless the environment state is asked for."""

import pytest
import torch
from hypothesis import given, settings, strategies as st
from lerobot.configs.types import FeatureType, PolicyFeature

from policies import inputs
from policies.bc import BCConfig, BCPolicy

STATE = ["index_pip.pos", "index_pip.vel", "palm.qw", "goal.index_pip", "object.x"]  # gloverec_sim's layout, before
NAMED = ["index_pip.pos", "index_pip.vel", "palm.qw.pos", "goal.index_pip.pos", "object.x.pos"]  # and now


def test_names_parse_and_unknown_ones_are_refused():
    assert inputs.parse("state, images,task") == ("state", "images", "task")
    assert inputs.parse(["images.front"]) == ("images.front",)
    with pytest.raises(ValueError, match="unknown input 'wrist'; valid: state, environment, images, task"):
        inputs.parse("state,wrist")
    with pytest.raises(ValueError, match="no inputs given"):
        inputs.parse(" , ")


@pytest.mark.parametrize("names", [STATE, NAMED], ids=["before", "named"])
def test_the_task_values_inside_the_state_are_environment_state(names):
    assert inputs.state_indices(names, ("state",)) == [0, 1, 2]
    assert inputs.state_indices(names, ("environment",)) == [3, 4]
    assert inputs.state_indices(STATE, ("state", "environment")) is None  # all of it
    features = {"observation.state": {"names": STATE}, "observation.images.top": {}}
    assert inputs.missing(("state", "environment", "images.top", "task"), features) == []
    assert inputs.missing(("images.front",), features) == ["camera front (it has top)"]
    assert inputs.missing(("environment",), {"observation.state": {"names": STATE[:3]}}) == ["environment state"]


def _policy(named, instructions=("open your hand", "make a fist")):
    cfg = BCConfig(device="cpu", push_to_hub=False, hidden_dim=16, n_layers=1, inputs=list(named),
                   instructions=list(instructions), chunk_size=2, temporal_ensemble_coeff=None)  # fmt: skip
    cfg.input_features = {
        "observation.state": PolicyFeature(FeatureType.STATE, (len(STATE),)),
        "observation.images.top": PolicyFeature(FeatureType.VISUAL, (3, 32, 32)),
    }
    cfg.output_features = {"action": PolicyFeature(FeatureType.ACTION, (4,))}
    cfg.set_dataset_feature_metadata({"observation.state": {"names": STATE}, "action": {"names": list("abcd")}})
    return BCPolicy(cfg)


def test_a_robot_policy_reads_neither_the_goal_nor_the_object_inside_the_state():
    batch = {"observation.state": torch.zeros(2, len(STATE)), "observation.images.top": torch.rand(2, 3, 32, 32),
             "task": ["make a fist", "open your hand"]}  # fmt: skip
    policy = _policy(inputs.ROBOT)
    assert policy.config.state_indices == [0, 1, 2] and policy.task_embedding is not None
    before = policy.predict_action_chunk(batch)
    batch["observation.state"][:, 3:] = 100.0  # the task's values: not read
    assert torch.equal(policy.predict_action_chunk(batch), before)
    batch["observation.state"][:, 0] = 1.0  # the robot's own: read
    assert not torch.equal(policy.predict_action_chunk(batch), before)
    with pytest.raises(ValueError, match="the policy does not know the instruction 'wave'"):
        policy.predict_action_chunk({**batch, "task": ["wave", "make a fist"]})

    images_only = _policy(("images",))
    assert list(images_only.config.input_features) == ["observation.images.top"] and not images_only.config.reads_task
    one_instruction = _policy(inputs.ROBOT, instructions=("pick it up",))  # lerobot-record's single_task
    assert not one_instruction.config.reads_task and one_instruction.task_embedding is None
    from policies.train import describe_inputs  # what `gloverec train` prints: the instruction left out, and why

    assert "not the task: every training episode has the same instruction" in describe_inputs(one_instruction.config)
    assert "not the task" not in describe_inputs(policy.config) and "not the task" not in describe_inputs(
        images_only.config
    )


@settings(max_examples=40, deadline=None)
@given(pad=st.integers(1, 4), n=st.integers(1, 3), seed=st.integers(0, 2**31 - 1))
def test_a_random_shift_moves_each_image_whole_by_at_most_pad_pixels(pad, n, seed):
    """`image_shift` (off by default, `policy: {image_shift: 4}` turns it on): each image of the batch is the
    original translated by one offset of at most ``pad`` pixels per axis, the border replicated."""
    from policies.bc.modeling_bc import random_shift

    torch.manual_seed(seed)
    images = torch.rand(n, 3, 12, 10)
    shifted = random_shift(images, pad)
    assert shifted.shape == images.shape
    rows, cols = torch.arange(12), torch.arange(10)
    for i in range(n):
        found = [
            (dy, dx)
            for dy in range(-pad, pad + 1)
            for dx in range(-pad, pad + 1)
            if torch.equal(shifted[i], images[i][:, (rows + dy).clamp(0, 11)][:, :, (cols + dx).clamp(0, 9)])
        ]
        assert found, f"image {i} is not a translation of at most {pad} px"
