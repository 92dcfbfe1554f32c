// Protocol frames, byte for byte against vectors made with the Python reference (recorder.protocol.codec):
//   encode_frame(EventFrame(0x1234, 0x89ABCDEF, EventCode.BUTTON, 0)).hex() etc.
// test_firmware.py checks many more frames against the Python decoder at run time.
#include <cstdio>
#include <cstring>
#include <string>

#include "check.h"
#include "legacy_json.h"
#include "protocol.h"

using namespace gc;

namespace {

std::string hex(const uint8_t* p, size_t n) {
    std::string s;
    char b[3];
    for (size_t i = 0; i < n; ++i) {
        std::snprintf(b, sizeof b, "%02x", p[i]);
        s += b;
    }
    return s;
}

size_t unhex(const char* s, uint8_t* out) {
    size_t n = 0;
    for (; s[0] && s[1]; s += 2) {
        unsigned v;
        std::sscanf(s, "%2x", &v);
        out[n++] = static_cast<uint8_t>(v);
    }
    return n;
}

const uint8_t kMux[12] = {0, 0, 1, 1, 2, 2, 3, 3, 4, 4, 5, 5};
const uint8_t kJoint[12] = {0, 1, 2, 3, 4, 5, 7, 8, 10, 11, 13, 14};

}  // namespace

TEST(event_frame_matches_python) {
    uint8_t out[kMaxWire];
    size_t n = encode_event(0x1234, 0x89ABCDEF, EventCode::Button, 0, out, sizeof out);
    CHECK(hex(out, n) == "0a01043412efcdab89020590db4d1000");
    n = encode_event(0, 0, EventCode::ImuFault, 7, out, sizeof out);
    CHECK(hex(out, n) == "0301040101010101070407e302acab00");
}

TEST(pose_frame_matches_python) {
    Quat q[16];
    q[1] = {0.5f, -0.5f, 0.25f, -1.0f};
    q[2] = {0.70710678f, 0.0f, 0.70710678f, 0.0f};
    uint8_t out[kMaxWire];
    const size_t n = encode_pose(7, 1000, q, 0x6DBF, out, sizeof out);
    CHECK(n == kPoseWire);
    CHECK(hex(out, n) ==
          "0401010703e8030103bf6d0240010101010101022002e0021004c0412d0103412d0101024001010101010102400101010101"
          "01024001010101010102400101010101010240010101010101024001010101010102400101010101010240010101010101"
          "024001010101010102400101010101010240010101010101024001010101010102400101010101052e67e60200");
}

TEST(pose_compact_frame_matches_python) {
    // encode_frame(PoseCompactFrame(7, 1000, [0.5, -0.5, 0.25, -1], radians(arange(20) * 10 - 95))).hex()
    real a[kJointAngles];
    for (int j = 0; j < kJointAngles; ++j) a[j] = static_cast<real>((j * 10 - 95) * 3.14159265358979323846 / 180);
    uint8_t out[kMaxWire];
    size_t n = encode_pose_compact(7, 1000, Quat{0.5f, -0.5f, 0.25f, -1.0f}, a, out, sizeof out);
    CHECK(n == kPoseCompactWire);
    CHECK(hex(out, n) == "0401050703e8030101022002e0021024c04aecca126dd7daede3a26ef06aeffc326009fae015c261228ae22e52"
                         "633ba046b32c00");
    // NaN -> -2048 (no value), saturation at +-204.7 degrees, ties to even
    for (auto& v : a) v = 0;
    a[0] = NAN;
    a[1] = 3.6f;
    a[2] = -3.6f;
    n = encode_pose_compact(7, 1000, identity(), a, out, sizeof out);
    CHECK(hex(out, n) == "0401050703e8030101024001010101010105f87f01080101010101010101010101010101010101010101010101"
                         "0105be7ddcb700");
    CHECK(deci_degrees(static_cast<real>(0.25 * 3.14159265358979323846 / 1800)) == 0);
    CHECK(deci_degrees(static_cast<real>(-1 * 3.14159265358979323846 / 1800)) == -1);
    CHECK(deci_degrees(static_cast<real>(3.14159265358979323846)) == 1800);
}

TEST(raw_frame_matches_python) {
    int16_t d[12][7];
    for (int i = 0; i < 12; ++i)
        for (int k = 0; k < 7; ++k) d[i][k] = static_cast<int16_t>((i * 7 + k) * 97 - 3000);
    uint8_t out[kMaxWire];
    const size_t n = encode_raw(65535, 4294967295u, d, 12, 16, 2000, 0xFFF, out, sizeof out);
    CHECK(n == 188);
    CHECK(hex(out, n) ==
          "4e0102ffffffffffff0c10d007ff0f48f4a9f40af56bf5ccf52df68ef6eff650f7b1f712f873f8d4f835f996f9f7f958fab9"
          "fa1afb7bfbdcfb3dfc9efcfffc60fdc1fd22fe83fee4fe45ffa6ff07026802c9692a018b01ec014d02ae020f037003d1033204"
          "9304f4045505b60517067806d9063a079b07fc075d08be081f098009e109420aa30a040b650bc60b270c880ce90c4a0dab0d0c"
          "0e6d0ece0e2f0f900ff10f5210b31014117511d61137129812f9125a13bb1332893bb000");
    CHECK(encode_raw(0, 0, d, 0, 16, 2000, 0, out, sizeof out) == 0);  // n_imu must be 1..16
}

TEST(status_frame_matches_python) {
    StatusInfo s;
    s.firmware[0] = 1;
    s.mode = Mode::Pose;
    s.sense_rate_hz = 100;
    s.output_rate_hz = 50;
    s.calib_state = 2;
    s.calib_progress = 100;
    s.glove_id = 0xDEADBEEF;
    s.imu_ok_mask = 0xFFF;
    s.n_imu = 12;
    s.mux_map = kMux;
    s.joint_map = kJoint;
    uint8_t out[kMaxWire];
    const size_t n = encode_status(3, 123456, s, out, sizeof out);
    CHECK(hex(out, n) ==
          "040103030440e201020101030164023203026408efbeaddeff0f0c010b0101020203030404050510010203040507080a0b0d0e"
          "cdf157a200");
}

TEST(encoder_counts_every_frame) {
    Encoder e;
    uint8_t out[kMaxWire];
    e.set_seq(65535);
    e.event(0, EventCode::Boot, 0, out, sizeof out);
    CHECK(e.seq() == 0);  // wraps at 65536
    CHECK(e.event(0, EventCode::Boot, 0, out, 4) == 0);
    CHECK(e.seq() == 0);  // a frame that did not fit was not sent, so it takes no number
}

TEST(q14_rounds_half_to_even_and_saturates) {
    CHECK(q14(1.0f) == 16384);
    CHECK(q14(-1.0f) == -16384);
    CHECK(q14(0.5f / 16384.0f) == 0);     // 0.5 -> 0
    CHECK(q14(1.5f / 16384.0f) == 2);     // 1.5 -> 2
    CHECK(q14(2.5f / 16384.0f) == 2);     // 2.5 -> 2
    CHECK(q14(-2.5f / 16384.0f) == -2);
    CHECK(q14(2.0f) == 32767);
    CHECK(q14(-2.0f) == -32768);
    CHECK(q14(NAN) == 0);
}

TEST(commands_from_python_decode) {
    struct V {
        const char* hex;
        CommandCode code;
        uint16_t arg;
    } v[] = {
        {"04011005010101010201051c7e73f1", CommandCode::SetMode, 0},
        {"0401100501010101070102301f7d1f", CommandCode::SetMode, 2},
        {"04011005010101010302c805a32397c7", CommandCode::SetRate, 200},
        {"04011005010101010603db4ff846", CommandCode::Recalibrate, 0},
        {"0401100501010101060478da9cd8", CommandCode::ResetPose, 0},
        {"04011005010101010605eeea9baf", CommandCode::GetStatus, 0},
    };
    for (const V& c : v) {
        uint8_t chunk[32];
        const size_t n = unhex(c.hex, chunk);
        Command cmd;
        CHECK(decode_command(chunk, n, &cmd));
        CHECK(cmd.code == c.code);
        CHECK(cmd.arg == c.arg);
        CHECK(cmd.seq == 5);
        // and our encoder produces the same bytes
        uint8_t out[64];
        const size_t m = encode_command(5, 0, cmd, out, sizeof out);
        CHECK(m == n + 1 && std::memcmp(out, chunk, n) == 0 && out[n] == 0);
    }
}

TEST(invalid_commands_are_rejected) {
    Command good{CommandCode::SetRate, 200, 1, 2}, cmd;
    uint8_t body[32], wire[64];
    // flip each bit of the encoded frame: no corruption may decode as a command
    const size_t n = encode_command(1, 2, good, wire, sizeof wire) - 1;
    int accepted = 0;
    for (size_t i = 0; i < n; ++i)
        for (int b = 0; b < 8; ++b) {
            uint8_t bad[64];
            std::memcpy(bad, wire, n);
            bad[i] = static_cast<uint8_t>(bad[i] ^ (1u << b));
            accepted += decode_command(bad, n, &cmd);
        }
    CHECK(accepted == 0);
    (void)body;
    // wrong kind (an event frame), bad mode value, unknown code, extra payload byte
    const size_t e = encode_event(0, 0, EventCode::Boot, 0, wire, sizeof wire);
    CHECK(!decode_command(wire, e - 1, &cmd));
    Command mode3{CommandCode::SetMode, 3, 0, 0};  // compact: valid
    size_t m = encode_command(0, 0, mode3, wire, sizeof wire);
    CHECK(decode_command(wire, m - 1, &cmd) && cmd.arg == 3);
    Command mode4{CommandCode::SetMode, 4, 0, 0};
    m = encode_command(0, 0, mode4, wire, sizeof wire);
    CHECK(!decode_command(wire, m - 1, &cmd));
    Command unknown{static_cast<CommandCode>(9), 0, 0, 0};
    m = encode_command(0, 0, unknown, wire, sizeof wire);
    CHECK(!decode_command(wire, m - 1, &cmd));
    Command status_with_arg{CommandCode::GetStatus, 0, 0, 0};
    m = encode_command(0, 0, status_with_arg, wire, sizeof wire);
    CHECK(decode_command(wire, m - 1, &cmd));
    CHECK(!decode_command(wire, 3, &cmd));  // truncated
}

TEST(command_reader_resyncs_on_garbage) {
    CommandReader r;
    uint8_t wire[64];
    const size_t n = encode_command(9, 0, Command{CommandCode::GetStatus, 0, 9, 0}, wire, sizeof wire);
    int got = 0;
    for (int i = 0; i < 100; ++i) got += r.feed(static_cast<uint8_t>(0x55 + i));  // garbage, overlong
    got += r.feed(0);
    CHECK(got == 0);
    CHECK(r.rejected() == 1);
    for (size_t i = 0; i < n; ++i) got += r.feed(wire[i]);
    CHECK(got == 1);
    CHECK(r.command().code == CommandCode::GetStatus && r.command().seq == 9);
    got += r.feed(0);  // empty chunk: nothing, not an error
    CHECK(got == 1 && r.rejected() == 1);
}

TEST(json_line_is_compact_and_exact) {
    Quat q[16];
    char line[kMaxJsonLine];
    size_t n = encode_json_line(q, line, sizeof line);
    const std::string ident = "{\"w\":1,\"x\":0,\"y\":0,\"z\":0}";
    std::string expect = "{\"wrists\":" + ident + ",\"fingers\":[";
    for (int f = 0; f < 5; ++f)
        expect += std::string(f ? "," : "") + "{\"joints\":[" + ident + "," + ident + "," + ident + "]}";
    expect += "]}\n";
    CHECK(std::string(line, n) == expect);
    q[0] = {0.1234565f, -0.5f, 1e-7f, -0.0000006f};  // rounding of the float value, sign of tiny values
    n = encode_json_line(q, line, sizeof line);
    CHECK(std::string(line, n).rfind("{\"wrists\":{\"w\":0.123457,\"x\":-0.5,\"y\":0,\"z\":-0.000001},", 0) == 0);
    CHECK(encode_json_line(q, line, 100) == 0);  // too small: nothing
}

TEST_MAIN()
