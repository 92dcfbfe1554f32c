"""gloverec policies: learning from the recorded demonstrations, with LeRobot (docs/policies.md).

``bc`` is the behaviour-cloning policy, LeRobot policy type ``gloverec_bc`` (importing it registers it);
``train``, ``evaluate`` and ``replay`` are the `gloverec train`, `gloverec eval` and `gloverec replay` commands,
whose flags live in ``cli`` (``add_parsers``). Nothing heavy is imported here: `gloverec --help` stays fast.
"""
