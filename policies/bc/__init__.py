"""The behaviour-cloning policy, LeRobot policy type ``gloverec_bc``. Importing this package registers it with
LeRobot (``PreTrainedConfig.register_subclass``), so ``make_policy``, ``make_pre_post_processors`` and
``lerobot-train --policy.type=gloverec_bc`` find it (lerobot-train imports it through the
``lerobot_policy_gloverec`` plugin distribution: policies/plugin/)."""

from policies.bc.configuration_bc import POLICY_TYPE, BCConfig
from policies.bc.modeling_bc import BCPolicy
from policies.bc.processor_bc import make_gloverec_bc_pre_post_processors

__all__ = ["POLICY_TYPE", "BCConfig", "BCPolicy", "make_gloverec_bc_pre_post_processors"]
