"""Imported by LeRobot's plugin discovery (distribution name `lerobot_policy_gloverec`): registers the gloverec
policies (policy type ``gloverec_bc``) with LeRobot's config registry and policy/processor factories."""

import policies.bc  # noqa: F401  (PreTrainedConfig.register_subclass("gloverec_bc"))
from policies.bc import BCConfig, BCPolicy, make_gloverec_bc_pre_post_processors

__all__ = ["BCConfig", "BCPolicy", "make_gloverec_bc_pre_post_processors"]
