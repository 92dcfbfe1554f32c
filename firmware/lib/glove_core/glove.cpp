#include "glove.h"

#include "imu_units.h"

namespace gc {

void Glove::init(const GloveSettings& settings, FrameSink* sink) {
    s_ = settings;
    if (s_.n_imu > kMaxImus) s_.n_imu = kMaxImus;
    if (s_.sense_rate_hz == 0) s_.sense_rate_hz = 1;
    sink_ = sink;
    enc_ = Encoder{};
    reader_ = CommandReader{};
    hand_.init(s_.hand, s_.n_imu, s_.joint_map);
    calib_.init(s_.calibration, s_.n_imu);
    mode_ = s_.mode;
    output_rate_ = s_.output_rate_hz < 1 ? 1 : (s_.output_rate_hz > s_.sense_rate_hz ? s_.sense_rate_hz
                                                                                      : s_.output_rate_hz);
    all_mask_ = static_cast<uint16_t>((1u << s_.n_imu) - 1u);
    ok_mask_ = all_mask_;
    pose_ready_ = started_ = false;
    has_last_t_ = 0;
    refusals_seen_ = 0;
    dropped_ = 0;
}

void Glove::begin(uint32_t t_us) {
    event(EventCode::Boot, 0, t_us);
    if (s_.calibrate_at_boot) {
        calib_.start();
        event(EventCode::CalibStart, 0, t_us);
    }
    status(t_us, false);
    next_status_ = t_us + s_.status_period_us;
    next_output_ = t_us;
    started_ = true;
}

bool Glove::due(uint32_t t_us, uint32_t& next, uint32_t period) {
    if (static_cast<int32_t>(t_us - next) < 0) return false;
    next += period;
    if (static_cast<int32_t>(t_us - next) >= 0) next = t_us + period;  // fell behind: skip, don't burst
    return true;
}

void Glove::sense(uint32_t t_us, const int16_t (*raw)[7], uint16_t ok_mask) {
    if (!started_) begin(t_us);
    ok_mask &= all_mask_;
    Vec3 gyro[kMaxImus], accel[kMaxImus];
    for (uint8_t i = 0; i < s_.n_imu; ++i) {
        const bool ok = ok_mask >> i & 1u, was_ok = ok_mask_ >> i & 1u;
        if (ok != was_ok) event(ok ? EventCode::ImuRecovered : EventCode::ImuFault, i, t_us);
        for (uint8_t k = 0; k < 7; ++k) raw_[i][k] = ok ? raw[i][k] : 0;  // a silent IMU's row is zeros
        gyro[i] = gyro_rad_s(raw_[i], s_.gyro_fs_dps);
        accel[i] = accel_g(raw_[i], s_.accel_fs_g);
    }
    ok_mask_ = ok_mask;

    if (calib_.running()) {
        for (uint8_t i = 0; i < s_.n_imu; ++i)
            if (ok_mask >> i & 1u) hand_.observe(i, accel[i]);  // keeps the median buffers full for the reset
        const CalibEvent ev = calib_.update(gyro, accel, ok_mask);
        if (ev == CalibEvent::Done) {
            event(EventCode::CalibDone, 0, t_us);
            reset_pose(t_us);
            status(t_us, false);
        } else if (ev == CalibEvent::Refused && (refusals_seen_ == 0 ||
                   t_us - last_refusal_event_ >= s_.status_period_us)) {  // at most one event a second
            event(EventCode::CalibRefused, 0, t_us);
            last_refusal_event_ = t_us;
            ++refusals_seen_;
        }
    } else if (!pose_ready_) {  // no calibration: start from this cycle's gravity (eq. 3.5-3.6)
        for (uint8_t i = 0; i < s_.n_imu; ++i)
            if (ok_mask >> i & 1u) hand_.observe(i, accel[i]);
        reset_pose(t_us);
    } else {
        const real nominal = real(1) / s_.sense_rate_hz;
        for (uint8_t i = 0; i < s_.n_imu; ++i) {
            if (!(ok_mask >> i & 1u)) continue;
            real dt = nominal;  // per-IMU time step: an IMU skipped for a while integrates its own gap
            if (has_last_t_ >> i & 1u) dt = static_cast<real>(t_us - last_t_[i]) * real(1e-6);
            if (dt > s_.max_dt_s) dt = s_.max_dt_s;
            hand_.update(i, calib_.corrected(i, gyro[i]), accel[i], dt);  // eq. 3.20, then eq. 3.4-3.19
        }
    }
    for (uint8_t i = 0; i < s_.n_imu; ++i)
        if (ok_mask >> i & 1u) last_t_[i] = t_us;
    has_last_t_ = static_cast<uint16_t>(has_last_t_ | ok_mask);

    if (due(t_us, next_status_, s_.status_period_us)) status(t_us, false);
    if (due(t_us, next_output_, 1000000u / output_rate_)) output(t_us);
}

void Glove::output(uint32_t t_us) {
    if (mode_ == Mode::Raw) {
        send(enc_.raw(t_us, raw_, s_.n_imu, s_.accel_fs_g, s_.gyro_fs_dps, ok_mask_, frame_, sizeof frame_));
        return;
    }
    if (!pose_ready_) return;  // calibrating: no pose yet
    Quat rel[kSegments];
    hand_.relative_pose(rel);
    if (mode_ == Mode::Pose) {
        send(enc_.pose(t_us, rel, hand_.measured_mask(), frame_, sizeof frame_));
    } else if (mode_ == Mode::Compact) {
        real angles[kJoints];
        joint_angles(rel, angles);
        send(enc_.pose_compact(t_us, rel[0], angles, frame_, sizeof frame_));
    } else {
        const size_t n = encode_json_line(rel, line_, sizeof line_);
        if (n && !sink_->write(reinterpret_cast<const uint8_t*>(line_), n)) ++dropped_;
    }
}

void Glove::send(size_t n, bool binary_answer) {
    if (n == 0 || !sink_) return;
    if (mode_ == Mode::Json) {
        // A legacy reader splits lines: binary frames would garble them. Only answers to commands go out, each
        // followed by '\n' so that at most that one "line" is unreadable.
        if (!binary_answer) return;
        frame_[n++] = '\n';
    }
    if (!sink_->write(frame_, n)) ++dropped_;
}

void Glove::event(EventCode code, uint8_t arg, uint32_t t_us) {
    send(enc_.event(t_us, code, arg, frame_, sizeof frame_ - 1));
}

void Glove::status(uint32_t t_us, bool answer) {
    StatusInfo st;
    for (int k = 0; k < 3; ++k) st.firmware[k] = s_.firmware[k];
    st.mode = mode_;
    st.sense_rate_hz = s_.sense_rate_hz;
    st.output_rate_hz = output_rate_;
    st.calib_state = static_cast<uint8_t>(calib_.state());
    st.calib_progress = calib_.progress();
    st.clock_flags = s_.clock_flags;
    st.glove_id = s_.glove_id;
    st.imu_ok_mask = ok_mask_;
    st.n_imu = s_.n_imu;
    st.mux_map = s_.mux_map;
    st.joint_map = s_.joint_map;
    send(enc_.status(t_us, st, frame_, sizeof frame_ - 1), answer);
}

void Glove::reset_pose(uint32_t t_us) {
    hand_.reset_pose();  // thesis §3.5.3: attitude from gravity again, and it becomes the reference (eq. 3.21)
    pose_ready_ = true;
    event(EventCode::PoseReset, 0, t_us);
}

void Glove::button(uint32_t t_us) {
    event(EventCode::Button, 0, t_us);
    reset_pose(t_us);
}

void Glove::receive(const uint8_t* data, size_t len, uint32_t t_us) {
    for (size_t i = 0; i < len; ++i)
        if (reader_.feed(data[i])) handle(reader_.command(), t_us);
}

void Glove::handle(const Command& c, uint32_t t_us) {
    switch (c.code) {
        case CommandCode::SetMode:
            mode_ = static_cast<Mode>(c.arg);
            next_output_ = t_us;
            break;
        case CommandCode::SetRate:
            if (c.arg < 1 || c.arg > s_.sense_rate_hz) return;  // invalid: ignored, no answer
            output_rate_ = c.arg;
            next_output_ = t_us;
            break;
        case CommandCode::Recalibrate:
            calib_.start();
            refusals_seen_ = 0;
            pose_ready_ = false;
            event(EventCode::CalibStart, 0, t_us);
            break;
        case CommandCode::ResetPose:
            if (pose_ready_) reset_pose(t_us);  // while calibrating, the reset follows the calibration anyway
            break;
        case CommandCode::GetStatus:
            break;
    }
    status(t_us, true);
}

}  // namespace gc
