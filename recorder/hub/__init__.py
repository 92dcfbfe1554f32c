"""The local hub: versioned, checksummed copies of LeRobot datasets in a folder (layout and guarantees: docs/hub.md).

``names`` (repo ids, version tags, where the hub is) -> ``dataset`` (is a folder a sound LeRobot v3.0 dataset?)
-> ``manifest`` (sha256 of every file; hash, copy, compare) -> ``atomic`` (temporary names, fsync, link switch)
-> ``store`` (push, pull, verify, list) -> ``cli`` (the `gloverec push` and `gloverec hub ...` commands).
``hf`` pushes a hub version on to the Hugging Face Hub. Nothing heavy is imported here: `gloverec --help` stays fast.
"""
