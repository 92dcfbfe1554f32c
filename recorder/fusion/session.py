"""Host fusion for a glove session (docs/fusion.md, "Calibration"): ``load_fusion`` builds a HostFusion for a
glove id from the fusion config and the glove's saved calibration; ``SessionFusion`` takes every glove frame and
hands on a HandPose for each one that carries the hand, whatever its format: it fuses raw frames (started from
the first ``rest_s`` of them, while the hand rests), reads pose and compact frames (the glove fused them),
re-takes the reference pose at the glove's button or a key, and hands its ``record`` (what travels with the
recording as meta/gloverec/calibration.json and in the session log's metadata) to its listeners once it is known.
"""

from __future__ import annotations

import dataclasses
import json
import math
import threading
from pathlib import Path

import numpy as np

from recorder import GloverecError
from recorder.config import ConfigError, build
from recorder.fusion.channels import ChannelMap, load_channel_map
from recorder.fusion.config import FusionConfig
from recorder.fusion.host import HostFusion, compile_kernels
from recorder.hand.calibration import GloveCalibration
from recorder.hand.kinematics import N_JOINTS, joint_angles_from_relative
from recorder.hand.pose import HandPose
from recorder.hand.skeleton import N_IMUS
from recorder.paths import calibration_dir
from recorder.protocol.frames import EventCode, EventFrame, PoseCompactFrame, PoseFrame, RawFrame, StatusFrame

RECORD_FILE = Path("meta") / "gloverec" / "calibration.json"
REST_S = 1.0  # the hand rests this long at the start of a session: fusion starts from it
STATUS_WAIT_S = 1.5  # after the rest, how long raw frames wait for a status frame (the glove id; 1 Hz)
COMPILE_NOTE_S = 3.0  # a warm-up that takes longer than this is announced while it runs (loading the cached kernels
# takes 0.2 s idle, and over a second on a loaded machine: not worth a line)


def load_config(path=None) -> FusionConfig:
    """The fusion config: FusionConfig's defaults, or a YAML file of overrides (configs/fusion/*.yaml are
    variants); a bad file: one-line ConfigError naming the file and the key."""
    return FusionConfig.load(path)


def read_calibration(path, glove_id: int | None = None) -> GloveCalibration:
    """A saved GloveCalibration; a corrupt file, another version or another glove's: one-line GloverecError."""
    try:
        text = Path(path).read_text()
    except OSError as exc:
        raise GloverecError(f"cannot read calibration {path}: {exc.strerror or exc}") from None
    try:
        calibration = GloveCalibration.from_json(text)
        _check_shapes(calibration)
    except (ValueError, KeyError, TypeError, AttributeError) as exc:
        raise GloverecError(f"bad calibration file {path}: {str(exc).splitlines()[0] or type(exc).__name__}") from None
    if glove_id is not None and calibration.glove_id != glove_id:
        raise GloverecError(f"{path} holds the calibration of glove {calibration.glove_id:08x}, not {glove_id:08x}")
    return calibration


def _check_shapes(c: GloveCalibration) -> None:
    want = {
        "gyro_bias": (N_IMUS, 3),
        "gyro_bias_temp_c": (N_IMUS,),
        "accel_offset": (N_IMUS, 3),
        "mounts": (N_IMUS, 4),
        "reference_angles": (N_JOINTS,),
    }
    for name, shape in want.items():
        if np.shape(getattr(c, name)) != shape:
            raise ValueError(f"{name} has shape {np.shape(getattr(c, name))}, expected {shape}")
    for name in ("gyro_bias", "accel_offset", "mounts", "reference_angles"):
        if not np.all(np.isfinite(getattr(c, name))):
            raise ValueError(f"{name} holds missing or non-finite values")


def load_fusion(glove_id: int, folder=None, config_path=None) -> HostFusion:
    """A HostFusion for glove ``glove_id``: the fusion config (FusionConfig's defaults unless ``config_path``)
    and the glove's saved calibration (``<folder>/glove_XXXXXXXX.json``, folder as in ``paths.calibration_dir``:
    the argument, $GLOVEREC_CALIBRATION_DIR or datasets/calibration). Without a saved calibration it fuses
    uncalibrated (identity mounts, no accelerometer offsets, the gyro bias from the rest at ``start``) and says
    so: ``fusion.calibrated`` is False."""
    config = load_config(config_path)
    path = GloveCalibration(glove_id=int(glove_id)).path(calibration_dir(folder))
    calibrated = path.exists()
    calibration = read_calibration(path, int(glove_id)) if calibrated else GloveCalibration(glove_id=int(glove_id))
    fusion = HostFusion(config, calibration)
    fusion.calibrated = calibrated
    fusion.calibration_path = path
    fusion.channels = read_channel_map(calibration_dir(folder), int(glove_id))
    return fusion


def read_channel_map(folder, glove_id: int) -> ChannelMap | None:
    """The glove's channel map (`gloverec doctor --fix`) beside its calibration; a damaged file: one line."""
    try:
        return load_channel_map(folder, glove_id)
    except (OSError, ValueError, KeyError, TypeError) as exc:
        where = ChannelMap(glove_id=int(glove_id)).path(folder)
        raise GloverecError(f"bad channel map {where}: {str(exc).splitlines()[0] or type(exc).__name__}") from None


def fusion_record(fusion: HostFusion | None, glove_id: int | None = None) -> dict:
    """What travels with a recording (meta/gloverec/calibration.json, the session log's ``calibration``):
    the glove id, whether it was calibrated, the calibration as saved (None when uncalibrated), the fusion
    config and whether the host fused (False: the glove sent fused poses; no calibration applies). Take it
    before ``start``, which refreshes the gyro bias from the rest."""
    if fusion is None:
        return {
            "glove_id": glove_id,
            "calibrated": False,
            "calibration": None,
            "fusion_config": None,
            "host_fusion": False,
            "rest_angles": None,
        }
    calibrated = bool(getattr(fusion, "calibrated", True))
    rest = None if fusion.rest_angles is None else np.asarray(fusion.rest_angles, float).tolist()
    return {
        "glove_id": int(fusion.calibration.glove_id),
        "calibrated": calibrated,
        "calibration": json.loads(fusion.calibration.to_json()) if calibrated else None,
        "fusion_config": dataclasses.asdict(fusion.config),
        "host_fusion": True,
        "rest_angles": rest,
        "channel_map": None if fusion.channels is None else json.loads(fusion.channels.to_json()),
    }


def fusion_from_record(record: dict, source: str = "the record") -> HostFusion | None:
    """The HostFusion a record describes (None for a glove that fused on board); a damaged record: GloverecError."""
    if not record.get("host_fusion"):
        return None
    try:
        # "engine" was a setting before the numba kernels became the one implementation: older records carry it
        values = {k: v for k, v in record["fusion_config"].items() if k != "engine"}
        config = build(FusionConfig, values, f"{source}: fusion_config")
        if record.get("calibrated"):
            calibration = GloveCalibration.from_json(json.dumps(record["calibration"]))
            _check_shapes(calibration)
        else:
            calibration = GloveCalibration(glove_id=int(record["glove_id"]))
    except ConfigError:
        raise
    except (ValueError, KeyError, TypeError, AttributeError) as exc:
        raise GloverecError(f"bad calibration in {source}: {str(exc).splitlines()[0] or type(exc).__name__}") from None
    fusion = HostFusion(config, calibration)
    if record.get("channel_map"):
        try:
            fusion.channels = ChannelMap.from_json(json.dumps(record["channel_map"]))
        except (ValueError, KeyError, TypeError) as exc:
            raise GloverecError(f"bad channel map in {source}: {exc}") from None
    fusion.calibrated = bool(record.get("calibrated"))
    if record.get("rest_angles") is not None:
        fusion.rest_angles = np.asarray(record["rest_angles"], float)
    return fusion


def write_record(folder, record: dict) -> Path:
    """Write ``record`` to ``folder``/meta/gloverec/calibration.json (atomically)."""
    path = Path(folder) / RECORD_FILE
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".tmp")
    tmp.write_text(json.dumps(record, indent=1))
    tmp.replace(path)
    return path


class SessionFusion:
    """The recorder's fusion for one glove session; ``process`` takes every glove frame.

    Raw frames: the first ``rest_s`` seconds of them (device time) are kept while the hand rests; then the
    HostFusion for the glove (``load_fusion`` with the id of the glove's status frames, or the one ``expect``
    or the log gave) is started from them (``HostFusion.start``: filters from gravity, gyro bias refreshed,
    reference pose taken) and every later raw frame is fused. Pose frames are left to the caller (the glove
    fused them). The glove's BUTTON event and ``request_reset`` (a key) re-take the reference pose."""

    def __init__(self, calibration_dir=None, config_path=None, rest_s: float = REST_S):
        self.folder = calibration_dir
        self.config_path = config_path
        self.rest_s = float(rest_s)
        self.glove_id: int | None = None
        self.rest_angles = None  # the pose the hand holds at start and reset (None: the reference pose)
        self.fusion: HostFusion | None = None
        self.host: bool | None = None  # True: raw frames, fused here; False: poses from the glove
        self.record: dict | None = None
        self.started = False
        self.resets = 0  # reference poses re-taken (button or key)
        self._rest: list[RawFrame] = []
        self._listeners: list = []
        self._reset_requested = False
        self._angles = np.zeros(N_JOINTS)  # the last measured value of every joint (held while not measured)
        self._palm = np.array([1.0, 0.0, 0.0, 0.0])

    @classmethod
    def from_record(cls, record: dict, source: str = "the record") -> SessionFusion:
        """Fuse as a recording did (its calibration.json or its log's ``calibration``): `gloverec rerecord`."""
        s = cls()
        s.glove_id = record.get("glove_id")
        s.fusion = fusion_from_record(record, source)
        s.host = s.fusion is not None
        if s.fusion is not None:
            s.rest_angles = s.fusion.rest_angles
        s._publish(dict(record))
        return s

    def expect(self, glove_id: int, raw: bool, rest_angles=None) -> None:
        """The glove is known before it sends (the emulator): its id, whether it sends raw frames, and the pose
        its wearer rests in. Loads the calibration now, so a bad file stops the session before it starts."""
        if self.record is not None:
            return
        self.glove_id = int(glove_id)
        self.rest_angles = None if rest_angles is None else np.asarray(rest_angles, float)
        self._decide(raw)

    def on_record(self, listener) -> None:
        """Call ``listener(record)`` once the record is known (now, if it is), and again if it changes."""
        self._listeners.append(listener)
        if self.record is not None:
            listener(self.record)

    def keep_in(self, folder, say=None) -> None:
        """Keep the record in ``folder``/meta/gloverec/calibration.json (a dataset's working copy); ``say`` gets
        a warning line when the host fuses without a saved calibration."""

        def keep(record: dict) -> None:
            write_record(folder, record)
            if say is None or not record.get("host_fusion"):
                return
            glove = f"glove {record.get('glove_id') or 0:08x}"
            where = getattr(self.fusion, "calibration_path", None)
            if record.get("calibrated"):
                say(f"{glove} sends raw IMU frames: fused on the host with its calibration {where or ''}".rstrip())
            else:
                say(
                    f"warning: {glove} sends raw IMU frames and has no saved calibration"
                    f"{f' ({where} not found)' if where else ''}: fusing uncalibrated; run `gloverec calibrate`"
                )

        self.on_record(keep)

    def warm_up(self, say=None) -> float:
        """Compile host fusion's kernels before any frame needs them (recorder/fusion/host.py compile_kernels),
        so the first raw frame never stalls a session; ``say`` gets a line when that takes more than
        COMPILE_NOTE_S (once per install). Returns the seconds it took."""
        config = self.fusion.config if self.fusion is not None else load_config(self.config_path)
        note = threading.Timer(
            COMPILE_NOTE_S,
            lambda: say("preparing host fusion: compiling its kernels (once per install, 10-30 s) or loading them..."),
        )
        if say is not None:
            note.start()
        try:
            seconds = compile_kernels(config)
        finally:
            note.cancel()
        if say is not None and seconds > COMPILE_NOTE_S:
            say(f"host fusion ready in {seconds:.0f} s (compiled and cached for later sessions)")
        return seconds

    @property
    def waiting(self) -> str | None:
        """What a raw glove's first hand pose waits for (None: nothing, or not a raw glove)."""
        if self.started or not self._rest:
            return None
        span = ((self._rest[-1].t_us - self._rest[0].t_us) & 0xFFFFFFFF) * 1e-6
        if span < self.rest_s:
            return f"host fusion starts from {self.rest_s:g} s of raw frames: hold the hand flat and still"
        return "host fusion waits for the glove's status frame (its id, for its calibration)"

    def request_reset(self) -> None:
        """Re-take the reference pose at the next raw frame (safe from another thread: a key reader)."""
        self._reset_requested = True

    @property
    def hold_until_s(self) -> float:
        """Session time (s) until which the hand should rest: the start of fusion (0 without host fusion)."""
        return self.rest_s + 0.25 if self.host else 0.0

    # ------------------------------------------------------------ frames
    def process(self, frame) -> HandPose | None:
        """The HandPose of a pose, compact or (once fusion has started) raw frame; None for every other frame.
        Joints a frame does not measure (non-finite values, IMUs fusion flagged) hold their last value and are
        marked not valid."""
        if isinstance(frame, RawFrame):
            fused = self._raw(frame)
            if fused is None:
                return None
            return self._pose(frame, fused.angles, fused.quats[0], fused.valid, fused.quality)
        if isinstance(frame, StatusFrame):
            if self.glove_id is None or self.fusion is None:
                self.glove_id = int(frame.glove_id)
        elif isinstance(frame, PoseFrame | PoseCompactFrame):
            if self.host is None:
                self._decide(raw=False)
            if isinstance(frame, PoseFrame):
                q = np.asarray(frame.quats, float)
                return self._pose(frame, joint_angles_from_relative(q), q[0])
            return self._pose(frame, np.asarray(frame.angles, float), np.asarray(frame.palm_quat, float))
        elif isinstance(frame, EventFrame) and frame.code == EventCode.BUTTON:
            self._reset()
        return None

    def _pose(self, frame, angles, palm, valid=True, quality: float = 0.0) -> HandPose:
        valid = np.isfinite(angles) & valid
        self._angles = np.where(valid, angles, self._angles)
        if 0.25 < float(np.dot(palm, palm)) < math.inf:  # finite, and of norm above 0.5
            self._palm = palm
        return HandPose(self._angles, self._palm, valid, float(quality), int(frame.t_us), int(frame.rx_ns))

    def _raw(self, frame: RawFrame):
        if self.started:
            if self._reset_requested:
                self._reset()
            return self.fusion.process(frame)
        self._rest.append(frame)
        span = ((frame.t_us - self._rest[0].t_us) & 0xFFFFFFFF) * 1e-6
        if span < self.rest_s or (self.glove_id is None and self.fusion is None and span < self.rest_s + STATUS_WAIT_S):
            return None
        if self.fusion is None or not self.host:
            self._decide(raw=True)
        rest = [f for f in self._rest if ((f.t_us - self._rest[0].t_us) & 0xFFFFFFFF) * 1e-6 <= self.rest_s]
        self.fusion.start(rest)
        for f in self._rest[len(rest) :]:  # frames that waited for the glove id: fused, not shown
            self.fusion.process(f)
        self.started, self._rest, self._reset_requested = True, [], False
        return None

    def _reset(self) -> None:
        self._reset_requested = False
        if self.started:
            self.fusion.reset()
            self.resets += 1

    def _decide(self, raw: bool) -> None:
        self.host = raw
        if raw and self.fusion is None:
            self.fusion = load_fusion(self.glove_id or 0, self.folder, self.config_path)
            self.fusion.rest_angles = self.rest_angles
        self._publish(fusion_record(self.fusion if raw else None, self.glove_id))

    def _publish(self, record: dict) -> None:
        self.record = record
        for listener in self._listeners:
            listener(record)
