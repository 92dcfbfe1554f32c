"""The text every view shows beside the scene, from the status a command publishes with each view frame:

    task         make the fist gesture
    episode      3 of 10: recording, 2.4 s left
    next         lift in 1.2 s
    success      2 of 2 so far
    glove        200 Hz, latency p99 7.9 ms, late 0, dropped 0
    wrist        tracked 98 % so far, last seen 40 ms ago   (a tracked wrist: "MARKER LOST 1.2 s ago: hold still ...")
    workspace    at its edge (front, bottom): the robot's palm stops there
    keys         F9 next | F10 record again | F11 zero | F12 stop | F8 human hand   (the web page: → n Enter next, ...)

``lines(status, key_names)`` gives (label, value) rows; ``columns(status)`` the two text columns MuJoCo's viewer
overlays.
"""

from __future__ import annotations

from recorder.wrist.config import SCRIPTED, seen

# The keys of the native view (MuJoCo's viewer binds Esc, the arrows, the letters and F1-F7 itself): they do what
# the terminal keys do. GLFW key codes.
KEYS = {297: "hand", 298: "next", 299: "rerecord", 300: "reset", 301: "stop"}  # F8 .. F12
KEY_NAMES = {"hand": "F8", "next": "F9", "rerecord": "F10", "reset": "F11", "stop": "F12"}
# The web page's keys: the terminal's (recorder/record/control.py), as the browser names them (KeyboardEvent.key),
# plus h for the human hand; a browser keeps F11 and F12 for itself.
WEB_KEYS = {
    "next": ("ArrowRight", "n", "Enter"),
    "rerecord": ("ArrowLeft", "r"),
    "reset": ("z",),
    "stop": ("Escape", "q"),
    "hand": ("h",),
    "takeover": ("t",),
}
_SHOWN = {"ArrowRight": "→", "ArrowLeft": "←", "Escape": "Esc"}
WEB_KEY_NAMES = {action: " ".join(_SHOWN.get(k, k) for k in keys) for action, keys in WEB_KEYS.items()}
TERMINAL_KEY_NAMES = {a: n for a, n in WEB_KEY_NAMES.items() if a != "hand"}  # views without keys of their own
ACTIONS = {"next": "next", "rerecord": "record again", "reset": "zero", "stop": "stop", "hand": "human hand",
           "takeover": "take over / give back"}  # fmt: skip
TAKEOVER_ONLY = ("takeover",)  # keys shown only in a takeover recording (a status with "control")


def lines(status: dict, key_names: dict[str, str] | None = None) -> list[tuple[str, str]]:
    """The overlay's rows, in order; rows the status has nothing for are left out. ``key_names``: how the view
    showing them names its keys (default: the native view's F-keys)."""
    key_names = KEY_NAMES if key_names is None else key_names
    rows = []
    if status.get("task"):
        rows.append(("task", str(status["task"])))
    if status.get("episode") is not None:
        ep = f"{status['episode'] + 1} of {status['episodes']}" if status.get("episodes") else str(status["episode"])
        phase = status.get("phase", "")
        if phase == "reset" and status.get("waiting"):
            phase = f"reset: waiting for {status['waiting']}"
        elif phase == "reset" and status.get("countdown") is not None:
            phase = f"reset, starts in {status['countdown']:.1f} s (or the glove's button, {key_names['next']})"
        elif phase == "recording" and status.get("time_left") is not None:
            phase = f"recording, {status['time_left']:.1f} s left"
        rows.append(("episode", f"{ep}: {phase}" if phase else ep))
    elif status.get("phase"):
        rows.append(("now", str(status["phase"])))
    if status.get("control"):
        key = key_names.get("takeover", "t")
        rows.append(("control", f"WEARER: the glove drives ({key} gives it back)" if status["control"] == "wearer"
                     else f"the policy ({key} or moving away from it takes over)"))  # fmt: skip
    if status.get("step"):
        rows.append(("step", str(status["step"])))
    if status.get("next"):
        rows.append(("next", str(status["next"])))
    if status.get("saved"):
        rows.append(("success", f"{status.get('successes', 0)} of {status['saved']} so far"))
    glove = status.get("glove")
    if glove:
        health = f"{glove.get('rate_hz', 0):.0f} Hz"
        if glove.get("latency_ms_p99") is not None:
            health += f", latency p99 {glove['latency_ms_p99']:.1f} ms"
        health += f", late {glove.get('late', 0)}, dropped {glove.get('dropped', 0)}"
        if not glove.get("up", True):
            health = "DOWN: waiting for the glove"
        rows.append(("glove", health))
    wrist = status.get("wrist")
    if wrist:
        rows.append(("wrist", wrist_text(wrist)))
        if wrist.get("edge"):
            rows.append(("workspace", f"at its edge ({sides(wrist['edge'])}): the robot's palm stops there"))
    keys = status.get("keys", [k for k in key_names if k not in TAKEOVER_ONLY or status.get("control")])
    if keys:
        rows.append(("keys", " | ".join(f"{key_names[k]} {ACTIONS[k]}" for k in keys if k in key_names)))
    return rows


# the workspace's sides as the wearer sees them, at the zero: fingers forward along +x, palm down
SIDES = {"x+": "front", "x-": "back", "y+": "left", "y-": "right", "z+": "top", "z-": "bottom"}


def sides(edge: list) -> str:
    return ", ".join(SIDES.get(e, e) for e in edge)


def wrist_text(wrist: dict) -> str:
    """The wrist row (recorder/view/wrist.py's status): its state, what to do when the tracker lost it."""
    state = wrist.get("state")
    if wrist.get("source") == SCRIPTED:
        return "the demonstrator's (scripted)"
    if state == "waiting":
        return "zeroed as the episode starts: palm flat and down, fingers forward"
    share = f"tracked {wrist.get('tracked_share', 0.0):.0%} so far"
    what = seen(wrist.get("source"))  # the registered source's name for what it tracks: marker, tracker
    if state == "lost":
        return f"{what.upper()} LOST {wrist.get('age_s', 0.0):.1f} s ago: hold still until it sees you again ({share})"
    if state == "catching up":
        return f"catching up: the {what} sees you again, the hand comes back slowly ({share})"
    return f"{share}, last seen {wrist.get('age_s', 0.0) * 1e3:.0f} ms ago"


def wrist_brief(wrist: dict | None) -> str:
    """The wrist in a few words, for the terminal's status line ("" without one)."""
    if not wrist or wrist.get("source") == SCRIPTED or wrist.get("state") in ("waiting", None):
        return ""
    state = wrist["state"]
    text = {"lost": f"wrist LOST {wrist.get('age_s', 0.0):.1f} s", "catching up": "wrist catching up"}.get(
        state, f"wrist {wrist.get('tracked_share', 0.0):.0%}"
    )
    return text + (" at the edge" if wrist.get("edge") else "")


def columns(status: dict) -> tuple[str, str]:
    """(labels, values): the two columns of MuJoCo's text overlay (the native view's keys)."""
    rows = lines(status)
    return "\n".join(r[0] for r in rows), "\n".join(r[1] for r in rows)
