"""The recording loop's precedence (recorder/record/precedence.py) and the view's pace (recorder/view/pace.py):
what keeps a browser showing the web view, or any other program, from delaying a real-time episode's frames."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import threading

import pytest

from recorder.config import ConfigError
from recorder.record import precedence
from recorder.view.pace import MIN_FPS, Pace

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
RR = os.SCHED_RR


def _granted() -> bool:
    return precedence.available()[0]


@pytest.mark.process
@pytest.mark.skipif(not hasattr(os, "sched_setscheduler"), reason="no scheduling classes on this system")
def test_an_episode_runs_the_loop_and_the_glove_in_the_real_time_class_then_gives_it_back(monkeypatch):
    monkeypatch.delenv(precedence.PRIORITY_ENV, raising=False)
    if not _granted():
        pytest.skip("this user may not use real-time scheduling (the refusal is tested as an unprivileged user)")
    ready, done, seen = threading.Event(), threading.Event(), {}

    def glove_thread():
        seen["tid"] = threading.get_native_id()
        ready.set()
        done.wait(10)

    other = threading.Thread(target=glove_thread, name="gloverec-serial:/dev/x", daemon=True)
    other.start()
    ready.wait(10)
    before = os.sched_getscheduler(0)
    with precedence.precedence(True):
        assert os.sched_getscheduler(0) & ~precedence._policy() == 0 and os.sched_getscheduler(0) & 0xF == RR
        assert os.sched_getscheduler(seen["tid"]) & 0xF == RR  # the glove's reader: on the latency path
        assert os.sched_getparam(0).sched_priority == precedence.RT_PRIORITY
        # what the loop starts (the view, the encoders, torch's pool) gets the normal class, never the real-time one
        child = subprocess.run([sys.executable, "-c", "import os; print(os.sched_getscheduler(0))"],
                               capture_output=True, text=True, check=True)  # fmt: skip
        assert int(child.stdout) == os.SCHED_OTHER
    assert os.sched_getscheduler(0) == before and os.sched_getscheduler(seen["tid"]) == before
    done.set()
    other.join(5)


def test_normal_is_kept_on_request_and_a_bad_value_is_one_line(monkeypatch):
    monkeypatch.setenv(precedence.PRIORITY_ENV, "normal")
    assert precedence.available() == (False, None)
    before = os.sched_getscheduler(0)
    with precedence.precedence(False):
        assert os.sched_getscheduler(0) == before
    monkeypatch.setenv(precedence.PRIORITY_ENV, "fastest")
    with pytest.raises(ConfigError, match="GLOVEREC_LOOP_PRIORITY='fastest': valid: realtime, normal"):
        precedence.wanted()


@pytest.mark.process
@pytest.mark.skipif(not shutil.which("setpriv") or not shutil.which("prlimit"), reason="needs util-linux's tools")
def test_a_user_without_real_time_scheduling_is_told_once_why_and_how():
    # `ulimit -r` 0 and no CAP_SYS_NICE, as for a user on a desktop without an rtprio limit
    code = "from recorder.record import precedence; print(precedence.available())"
    r = subprocess.run(["prlimit", "--rtprio=0", "setpriv", "--bounding-set=-sys_nice", "--inh-caps=-sys_nice",
                        sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT,
                       env={**os.environ, "PYTHONPATH": ROOT})  # fmt: skip
    assert r.returncode == 0, r.stderr
    assert r.stdout.startswith("(False, 'the recording loop runs at normal priority"), r.stdout
    assert "ulimit -r" in r.stdout and "docs/recording.md" in r.stdout


def test_the_view_slows_down_when_the_recording_is_late_and_says_so():
    pace, t = Pace(20.0), 0.0
    for _ in range(40):  # on time: the full rate, and nothing to say
        t += pace.period({"late_ms": 0.2}, now=t)
    assert pace.fps == 20.0 and pace.note() is None
    for _ in range(16):  # the loop reports late ticks: the view halves its rate down to the floor
        t += pace.period({"late_ms": 12.0}, now=t)
    assert pace.fps == MIN_FPS
    assert pace.note() == "slowed to 4 frames/s to keep the recording on time"
    for _ in range(60):  # on time again: back to the full rate
        t += pace.period({"late_ms": 0.0}, now=t)
    assert pace.fps == 20.0 and pace.note() is None


def test_a_tick_late_by_a_small_share_of_its_period_does_not_slow_the_view():
    pace, t = Pace(20.0), 0.0
    for _ in range(40):  # 2.5 ms late at 30 fps (33 ms ticks): as a loaded machine gives, harmless
        t += pace.period({"late_ms": 2.5, "period_ms": 1e3 / 30}, now=t)
    assert pace.fps == 20.0 and not pace.backed_off
    pace.period({"late_ms": 2.5, "period_ms": 10.0}, now=t)  # at 100 fps it is a quarter of the period
    assert pace.backed_off and pace.fps == 10.0


def test_a_view_starved_of_cpu_says_what_it_draws_with():
    pace, t = Pace(20.0), 0.0
    for _ in range(10):  # asked for 20 frames/s, drew 5: the machine is busy, the recording is not late
        pace.period({"late_ms": 0.0}, now=t)
        t += 0.2
    assert pace.note() == "5 frames/s: the view draws with the CPU the recording and other programs leave"
