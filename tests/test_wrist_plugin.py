"""A wrist source is registered, not special-cased (recorder/wrist/config.py ``@register_wrist_source``, docs/wrist.md
"Adding a wrist source"): the built-in kinds parse as they are spelled, a plugin module's source
(tests/plugins/mocap_wrist.py: ``mocap:SCALE``, a motion-capture system following the emulated wearer) parses,
checks its address and is listed with the others, and `gloverec record --wrist mocap:SCALE` records its poses
into ``observation.wrist``."""

import os
import shutil
import sys
from pathlib import Path

import numpy as np
import pytest

import envs
from conftest import cli, gloverec
from recorder.config import ConfigError
from recorder.wrist import config
from recorder.wrist.config import WristConfig

PLUGINS = Path(__file__).parent / "plugins"


@pytest.fixture
def mocap(monkeypatch):
    """tests/plugins/mocap_wrist.py registered in this process, in a copy of the registry (the other tests see the
    built-in sources only)."""
    config.kinds()  # the built-in sources registered first
    monkeypatch.setattr(config, "_SOURCES", dict(config._SOURCES))
    monkeypatch.syspath_prepend(str(PLUGINS))
    monkeypatch.delitem(sys.modules, "mocap_wrist", raising=False)
    import mocap_wrist  # noqa: F401  (registers mocap on import)


def test_the_built_in_sources_parse_as_they_are_spelled():
    for spec, kind, address in (
        ("udp:9100", "udp", "0.0.0.0:9100"),
        ("udp:127.0.0.1:9100", "udp", "127.0.0.1:9100"),
        ("marker:0", "marker", "0"),
        ("marker:clip.mkv", "marker", "clip.mkv"),
        ("marker:emulated", "marker:emulated", ""),
        ("marker:emulated:7,-6,8", "marker:emulated", "7,-6,8"),
        ("mcap:session.mcap", "mcap", "session.mcap"),
    ):
        c = WristConfig.parse(spec)
        assert (c.kind, c.address) == (kind, address), spec
        assert str(WristConfig.parse(str(c))) == str(c)
    assert WristConfig.parse("marker:emulated").follows_wearer and not WristConfig.parse("marker:0").follows_wearer
    assert WristConfig.parse("scripted").source is None and not WristConfig.parse("scripted").follows_wearer
    assert [config.seen(k) for k in ("marker", "marker:emulated", "udp", "mcap")] == ["marker", "marker", "tracker",
                                                                                    "tracker"]  # fmt: skip
    for bad, says in (
        ("marker:emulated:7,x,8", "bad wrist source 'marker:emulated:7,x,8': marker:emulated:RX,RY,RZ glues"),
        ("marker:", "unknown wrist source 'marker:'"),
        ("udp:70000", "bad wrist source 'udp:70000': the port must be 1-65535"),
    ):
        with pytest.raises(ConfigError) as err:
            WristConfig.parse(bad)
        assert says in str(err.value), err.value


def test_a_plugin_s_source_parses_checks_its_address_and_is_listed(mocap, tmp_path):
    c = WristConfig.parse("mocap:0.5")
    assert (c.kind, c.address, str(c)) == ("mocap", "0.5", "mocap:0.5") and c.follows_wearer
    assert "mocap" in config.kinds()
    assert config.specs().endswith(" or mocap:SCALE (the emulated wearer, motion-captured)")
    with pytest.raises(ConfigError, match="bad wrist source 'mocap:-1': expected mocap:SCALE"):
        WristConfig.parse("mocap:-1")
    with pytest.raises(ConfigError, match="unknown wrist source 'mocup:1'; valid: scripted, .* or mocap:SCALE"):
        WristConfig.parse("mocup:1")
    with pytest.raises(ConfigError, match="wrist source 'udp' is registered already"):
        config.register_wrist_source("udp")(lambda c, **o: None)
    # a source that follows the emulated wearer opens only where there is one (record, calibrate --wrist)
    r = cli("wrist", "--wrist", "mocap:1", "--duration", "0.2")
    assert r.returncode == 1 and "mocap:1 follows the emulated wearer" in r.stderr, r.stderr
    assert r.stderr.count("\n") == 1, r.stderr
    r = cli("record", "--view", "none", "--task", "relocate", "--glove", "udp:9", "--wrist", "mocap:1",
            "--root", str(tmp_path / "ds"), "--repo-id", "test/none")  # fmt: skip
    assert r.returncode == 1 and "--wrist mocap films the emulated wearer: record with --glove emulator" in r.stderr
    assert not (tmp_path / "ds").exists()


@pytest.mark.process
def test_a_plugin_s_wrist_source_drives_the_recorded_wrist(tmp_path):
    """A module named in GLOVEREC_PLUGINS registers mocap in `gloverec record`'s own process; the emulated wearer
    grasps with a free wrist, and the recorded wrist moves half as far as the wearer's palm, as mocap:0.5 reports
    it: down by half the task's hover height onto the object, then up by half its lift."""
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    shutil.copy(PLUGINS / "mocap_wrist.py", tmp_path / "my_mocap.py")
    env = {**os.environ, "GLOVEREC_PLUGINS": "my_mocap", "GLOVEREC_CALIBRATION_DIR": str(tmp_path / "calibration"),
           "PYTHONPATH": os.pathsep.join(p for p in (str(tmp_path), os.environ.get("PYTHONPATH")) if p)}  # fmt: skip
    root = tmp_path / "ds"
    r = gloverec("record", "--task", "grasp", "--glove", "emulator", "--wrist", "mocap:0.5", "--episodes", "1",
                 "--fast", "--root", str(root), "--repo-id", "test/mocap", env=env, timeout=120)  # fmt: skip
    assert r.returncode == 0, r.stderr
    ds = LeRobotDataset("test/mocap", root=root)
    assert ds.num_episodes == 1 and ds.meta.features["action"]["names"][-3:] == ["base.x", "base.y", "base.z"]
    assert np.mean(ds.hf_dataset["quality.wrist_tracked"]) > 0.99  # every pose tracked, none late
    z = np.array(ds.hf_dataset["observation.wrist"])[:, 2]
    task = envs.make("grasp").unwrapped.config
    down, up = z[0] - z.min(), z[-1] - z.min()
    assert abs(down - 0.5 * task.hover_m) < 0.1 * task.hover_m, (down, task.hover_m)  # the wearer's: hover_m
    assert abs(up - 0.5 * task.lift_m) < 0.1 * task.lift_m, (up, task.lift_m)
