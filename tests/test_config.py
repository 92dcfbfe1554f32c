"""The one config mechanism (recorder/config.py): dataclass defaults, then a YAML file, then flags generated from
the fields; today's flags work as before; every problem is one line naming the file (or flag) and the key."""

import argparse

import pytest
from hypothesis import given, strategies as st

from conftest import cli
from policies.config import TrainConfig
from recorder import config
from recorder.config import ConfigError
from recorder.glove import config as glove
from recorder.glove.config import GloveConfig, LinkConfig
from recorder.paths import calibration_dir, config_file, hub_dir
from recorder.record.config import RecordConfig


def _record(*argv, path=None):
    p = argparse.ArgumentParser()
    config.add_arguments(p, RecordConfig)
    return RecordConfig.load(path, **config.overrides(p.parse_args(argv), RecordConfig))


def test_defaults_live_in_the_dataclass():
    cfg = _record()
    assert cfg == RecordConfig() and cfg.glove == GloveConfig() and cfg.is_fast
    assert cfg.root_path.as_posix() == "datasets/recordings/local/glove_demos"


def test_todays_flags_work_as_before():
    cfg = _record(
        "--glove",
        "serial:/dev/ttyACM0",
        "--realtime",
        "--cameras",
        "front,top",
        "--no-log",
        "--glove-rate",
        "500",
        "--glove-output",
        "raw",
        "--resume",
        "--episode-time-s",
        "4.5",
    )
    assert cfg.glove == GloveConfig("serial", "/dev/ttyACM0", rate_hz=500.0, mode="raw")
    assert cfg.realtime is True and not cfg.is_fast and cfg.cameras == ("front", "top")
    assert cfg.log is False and cfg.resume is True and cfg.episode_time_s == 4.5
    assert _record("--fast", "--glove", "/dev/ttyUSB0").is_fast  # a bare device path is a serial glove
    assert _record("--glove", "udp:9000").glove.udp_address() == ("0.0.0.0", 9000)
    with pytest.raises(SystemExit):
        _record("--realtime", "--fast")  # exclusive
    t = argparse.ArgumentParser()
    config.add_arguments(t, TrainConfig)
    train = TrainConfig.load(None, **config.overrides(t.parse_args(["--all-episodes", "--steps", "7"]), TrainConfig))
    assert train.successful_only is False and train.steps == 7 and train.save_every == 1000


def test_renamed_flags_still_take_their_old_names(capsys):
    """A field's ``aliases`` (and a nested flag's old names): the old name sets the same field after a one-line
    note on stderr (stdout is left alone); --help shows the new name only; a required flag may be given by either."""
    p = argparse.ArgumentParser(prog="t")
    config.add_arguments(p, LinkConfig, required=("glove",))
    new = config.overrides(p.parse_args(["--glove", "udp:9000"]), LinkConfig)
    assert capsys.readouterr() == ("", "")
    old = config.overrides(p.parse_args(["--port", "udp:9000", "--baud", "9600"]), LinkConfig)
    assert new == {"glove": "udp:9000"} and old == {"glove": "udp:9000", "glove.baudrate": 9600}
    assert capsys.readouterr() == ("", "t: note: --port is now --glove; --port goes in a later release\n")
    assert "--port" not in p.format_help() and "--glove GLOVE" in p.format_usage()
    with pytest.raises(SystemExit):
        p.parse_args([])
    assert "--glove is required" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        p.parse_args(["--glove", "udp:1", "--port", "udp:2"])  # one name or the other
    capsys.readouterr()
    assert _record("--glove-mode", "raw").glove == _record("--glove-output", "raw").glove == GloveConfig(mode="raw")
    assert "--glove-mode is now --glove-output" in capsys.readouterr().err


def test_yaml_overrides_defaults_and_flags_override_yaml(tmp_path):
    path = tmp_path / "rec.yaml"
    path.write_text("robot: shadow\nglove: {kind: serial, address: /dev/ttyACM0, baudrate: 9600}\nfps: 50\n")
    cfg = _record("--fps", "20", "--glove-rate", "100", path=path)
    assert cfg.robot == "shadow" and cfg.fps == 20
    assert cfg.glove == GloveConfig("serial", "/dev/ttyACM0", baudrate=9600, rate_hz=100.0)
    cfg = _record("--glove", "mcap:x.mcap", path=path)  # a spec replaces the kind and address, keeps the rest
    assert cfg.glove == GloveConfig("mcap", "x.mcap", baudrate=9600)


@pytest.mark.parametrize(
    "text, message",
    [
        ("fps: 0\n", "rec.yaml: fps: Input should be greater than 0"),
        ("fps: fast\n", "rec.yaml: fps: Input should be a valid integer"),
        ("frames_per_second: 30\n", "rec.yaml: frames_per_second: unknown key; valid: glove, robot, task, retarget"),
        ("glove: {kind: serial}\n", "rec.yaml: glove: a serial glove needs an address"),
        ("glove: {kind: serial, address: x, speed: 3}\n", "rec.yaml: glove.speed: unknown key; valid: kind, address"),
        ("glove: 'udp:host:99999'\n", "bad UDP glove"),
        ("cameras: [front, ceiling]\n", "rec.yaml: cameras.1: Input should be 'front', 'top' or 'side'"),
        ("repo_id: ../etc\n", "rec.yaml: repo_id: bad repo id '../etc'"),
        ("[1, 2]\n", "rec.yaml: expected a mapping of settings, got list"),
        ("fps: [\n", "rec.yaml: not valid YAML"),
    ],
)
def test_bad_files_are_one_line_naming_the_file_and_key(tmp_path, text, message):
    path = tmp_path / "rec.yaml"
    path.write_text(text)
    with pytest.raises(ConfigError) as exc:
        RecordConfig.load(path)
    assert message in str(exc.value) and "\n" not in str(exc.value), str(exc.value)


def test_the_command_line_reports_config_errors_in_one_line(tmp_path):
    path = tmp_path / "rec.yaml"
    path.write_text("episodes: -1\n")
    r = cli("record", "--config", str(path))
    assert r.returncode == 1 and r.stderr.count("\n") == 1 and "episodes: Input should be greater than 0" in r.stderr
    r = cli("record", "--config", str(tmp_path / "missing.yaml"))
    assert r.returncode == 1 and "no such config file" in r.stderr
    r = cli("record", "--fps", "0")  # flag values are checked by argparse: exit 2
    assert r.returncode == 2 and "--fps: must be positive" in r.stderr and r.stderr.count("\n") == 1
    r = cli("train", "--repo-id", "a/b", "--out", str(tmp_path / "o"), "--val-fraction", "1")
    assert r.returncode == 2 and "--val-fraction: must be below 1" in r.stderr


def test_shipped_example_configs_load():
    assert RecordConfig.load(config_file("record", "shadow_grasp")).robot == "shadow"
    assert RecordConfig.load(config_file("record", "serial_glove")).glove.kind == "serial"
    assert TrainConfig.load(config_file("train", "quick")).policy == {"hidden_dim": 256}
    assert TrainConfig.load(config_file("train", "history")).policy == {"n_obs_steps": 4, "obs_stride": 8}


specs = st.one_of(
    st.just("emulator"),
    st.builds("serial:/dev/{}".format, st.from_regex(r"tty[A-Z]{3}[0-9]", fullmatch=True)),
    st.builds("udp:{}".format, st.integers(1, 65535)),
    st.builds("udp:127.0.0.{}:{}".format, st.integers(1, 254), st.integers(1, 65535)),
    st.builds("mcap:{}.mcap".format, st.from_regex(r"[a-z][a-z0-9_/]{0,12}", fullmatch=True)),
)


@given(specs)
def test_glove_specs_round_trip(spec):
    glove = GloveConfig.parse(spec)
    assert str(glove) == spec and GloveConfig.parse(str(glove)) == glove


def test_the_emulator_is_a_registered_glove_source():
    """`emulator` is a glove source like the others (recorder/glove/sources.py): listed first, no device, written
    without an address (one is a one-line error), its name not a plugin's to take."""
    source = glove.glove_source("emulator")
    assert glove.kinds()[:4] == ("emulator", "serial", "udp", "mcap") and not source.address and not source.device
    assert glove.specs().startswith("emulator, serial:PORT") and str(GloveConfig()) == "emulator"
    with pytest.raises(ConfigError, match="^bad glove 'emulator:x': expected emulator, serial:PORT"):
        GloveConfig.parse("emulator:x")
    with pytest.raises(ConfigError, match="glove source 'emulator' is registered already"):
        glove.register_glove_source("emulator", device=False, address=False)(lambda config, realtime, **options: None)


@given(st.text(max_size=12))
def test_any_glove_text_parses_or_is_a_config_error(text):
    try:
        GloveConfig.parse(text)
    except ConfigError as exc:
        assert "\n" not in str(exc)


def test_data_folders_follow_the_environment(monkeypatch, tmp_path):
    monkeypatch.delenv("GLOVEREC_HUB", raising=False)
    monkeypatch.delenv("GLOVEREC_CALIBRATION_DIR", raising=False)
    assert hub_dir().as_posix() == "datasets/hub" and calibration_dir().as_posix() == "datasets/calibration"
    monkeypatch.setenv("GLOVEREC_HUB", str(tmp_path / "hub"))
    monkeypatch.setenv("GLOVEREC_CALIBRATION_DIR", str(tmp_path / "cal"))
    assert hub_dir() == tmp_path / "hub" and calibration_dir() == tmp_path / "cal"
    assert hub_dir("elsewhere").as_posix() == "elsewhere"
