"""The web view: for headless machines and remote operators. A page served on 127.0.0.1 (another address only
when asked: ``--view web:0.0.0.0:8765``) with the live scene rendered offscreen (EGL) as an MJPEG stream while a
page shows it, the status text (``/status``, with the frames drawn so far), and buttons for next, record again,
zero, stop and take over, each also on a key (the terminal's: → n Enter, ← r, z, Esc q, t: control between the
policy and the wearer in a takeover recording; h shows or hides the human hand). Each browser is served by its own
thread that sends the newest frame when it can, so a slow or closed page never holds up the rendering, let alone
the recording (which runs in another process, its episodes in the real-time scheduling class where allowed:
recorder/record/precedence.py). The page loses frames instead: the view draws with the CPU the recording leaves
(recorder/view/process.py, its priority), backs off while the recording reports late ticks, and says so in a
"view" row. The standard library's HTTP
server is enough for one page, a stream and five buttons on a local network.
"""

from __future__ import annotations

import io
import json
import threading
import time
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer

import mujoco
from PIL import Image

from recorder.view import overlay
from recorder.view.pace import Pace
from recorder.view.scene import Stage, free_camera

FPS = 20.0
SIZE = (480, 640)  # height, width
PAGE = """<!doctype html>
<html><head><meta charset="utf-8"><title>gloverec</title>
<style>
 body { background: #1e2227; color: #e6e6e6; font: 15px system-ui, sans-serif; margin: 16px; }
 #scene { width: 640px; height: 480px; background: #000; display: block; }
 table { border-collapse: collapse; margin: 10px 0; } td { padding: 2px 12px 2px 0; vertical-align: top; }
 td.k { color: #9aa4ad; } tr.warn td { color: #ff6b6b; font-weight: 600; } tr.edge td { color: #f07ae6; }
 button { font-size: 15px; margin-right: 8px; padding: 6px 14px; }
</style></head><body>
<img id="scene" src="/stream" alt="the scene">
<table id="status"></table>
<div>BUTTONS</div>
<script>
const KEYS = KEYMAP;
const TAKEOVER_ONLY = TAKEOVERONLY;
for (const id of TAKEOVER_ONLY) document.getElementById(id).hidden = true;
const press = (name) => fetch("/key/" + name, {method: "POST"});
for (const b of document.querySelectorAll("button")) b.onclick = () => press(b.id);
document.addEventListener("keydown", (e) => {
  if (e.ctrlKey || e.metaKey || e.altKey || !(e.key in KEYS)) return;
  e.preventDefault();
  press(KEYS[e.key]);
});
async function status() {
  try {
    const rows = (await (await fetch("/status")).json()).rows;
    // TAKEOVER_ONLY's buttons do something only in a takeover recording, whose status has a "control" row
    const takeover = rows.some(([k]) => k === "control");
    for (const id of TAKEOVER_ONLY) document.getElementById(id).hidden = !takeover;
    document.getElementById("status").innerHTML = rows.map(
      ([k, v]) => `<tr class="${v.includes("LOST") ? "warn" : k === "workspace" || k === "view" ||
        v.startsWith("WEARER") ? "edge" : ""}">` +
        `<td class="k">${k}</td><td>${v.replace(/&/g, "&amp;").replace(/</g, "&lt;")}</td></tr>`
    ).join("");
  } catch (e) {}
  setTimeout(status, 250);
}
status();
</script></body></html>
"""


PAGE = (
    PAGE.replace(
        "BUTTONS",
        "".join(
            f'<button id="{a}">{overlay.ACTIONS[a]} ({overlay.WEB_KEY_NAMES[a]})</button>' for a in overlay.WEB_KEYS
        ),
    )
    .replace("KEYMAP", json.dumps({key: action for action, keys in overlay.WEB_KEYS.items() for key in keys}))
    .replace("TAKEOVERONLY", json.dumps(list(overlay.TAKEOVER_ONLY)))
)


class _Frames:
    """The newest JPEG and status, with a condition the stream handlers wait on, and whether anyone looks: a
    frame is rendered only for an open stream or a /frame.jpg waiting for one (software rendering takes tens of
    milliseconds of a core per frame, spent for nobody while no page is open)."""

    def __init__(self):
        self.cond = threading.Condition()
        self.jpeg = b""
        self.rows: list = []
        self.seq = 0
        self.streams = 0  # open /stream answers
        self.asked = 0  # /frame.jpg answers waiting for a frame

    @property
    def watched(self) -> bool:
        with self.cond:
            return self.streams > 0 or self.asked > 0

    def put(self, jpeg: bytes, rows: list) -> None:
        with self.cond:
            self.jpeg, self.rows, self.seq = jpeg, rows, self.seq + 1
            self.cond.notify_all()

    def status(self, rows: list) -> None:
        """The status rows without a new image (nobody looks at the scene)."""
        with self.cond:
            self.rows = rows

    def snapshot(self, timeout: float = 30.0) -> bytes:
        """A frame rendered after the request (the last one, if none comes within ``timeout``: the view renders
        with the CPU the recording leaves; empty if it never drew one)."""
        with self.cond:
            self.asked += 1
            seq = self.seq
            try:
                self.cond.wait_for(lambda: self.seq != seq, timeout)
            finally:
                self.asked -= 1
            return self.jpeg

    def after(self, seq: int, timeout: float = 1.0) -> tuple[int, bytes]:
        with self.cond:
            self.cond.wait_for(lambda: self.seq != seq, timeout)
            return self.seq, self.jpeg


def serve(
    stage: Stage, shared, events, closing, host: str = "127.0.0.1", port: int = 8765, ready=None, meter=None
) -> None:
    """Serve the page and render frames until ``closing()``; ``events(name)`` sends a button's request back;
    ``ready(url)`` is called once the server listens."""
    frames = _Frames()
    server = ThreadingHTTPServer((host, port), _handler(frames, events, stage))
    server.daemon_threads = True
    threading.Thread(target=server.serve_forever, kwargs={"poll_interval": 0.2}, daemon=True).start()
    if ready is not None:
        ready(f"http://{host}:{server.server_address[1]}/")
    renderer = mujoco.Renderer(stage.model, *SIZE)
    camera, opt = free_camera(stage), mujoco.MjvOption()
    pace, period, last = Pace(FPS), 1.0 / FPS, None
    try:
        while not closing():
            t = time.monotonic()
            frame = shared.read()
            if frame is not None:
                last = frame
                stage.apply(frame)
            if last is not None and not frames.watched:
                frames.status(overlay.lines(last.status, overlay.WEB_KEY_NAMES))
            elif last is not None:
                renderer.update_scene(stage.data, camera=camera, scene_option=opt)
                stage.decorate(renderer.scene, opt)
                buf = io.BytesIO()
                Image.fromarray(renderer.render()).save(buf, "JPEG", quality=80)
                period = pace.period(last.status)
                note = pace.note()  # the page says when it shows fewer frames, and why
                rows = overlay.lines(last.status, overlay.WEB_KEY_NAMES) + ([("view", note)] if note else [])
                frames.put(buf.getvalue(), rows)
                if meter is not None:
                    meter.tick()
            time.sleep(max(0.0, period - (time.monotonic() - t)))
    finally:
        server.shutdown()
        server.server_close()
        renderer.close()


def _handler(frames: _Frames, events, stage: Stage):
    class Handler(BaseHTTPRequestHandler):
        def log_message(self, *args) -> None:  # quiet: the command's own output is what the operator reads
            pass

        def do_GET(self) -> None:
            if self.path in ("/", "/index.html"):
                self._send(200, "text/html; charset=utf-8", PAGE.encode())
            elif self.path == "/status":
                self._send(200, "application/json", json.dumps({"rows": frames.rows, "frames": frames.seq}).encode())
            elif self.path == "/frame.jpg":
                jpeg = frames.snapshot()
                if jpeg:
                    self._send(200, "image/jpeg", jpeg)
                else:
                    self._send(503, "text/plain", b"no frame drawn yet")
            elif self.path == "/stream":
                self._stream()
            else:
                self._send(404, "text/plain", b"not found")

        def do_POST(self) -> None:
            name = self.path.removeprefix("/key/")
            if name == "hand":
                stage.show_hand = not stage.show_hand
            elif name in overlay.ACTIONS:
                events(name)
            else:
                return self._send(404, "text/plain", b"no such key")
            self._send(204, "text/plain", b"")

        def _send(self, code: int, kind: str, body: bytes) -> None:
            try:
                self.send_response(code)
                self.send_header("Content-Type", kind)
                self.send_header("Content-Length", str(len(body)))
                self.send_header("Cache-Control", "no-store")
                self.end_headers()
                self.wfile.write(body)
            except (BrokenPipeError, ConnectionResetError):
                pass  # the page went away mid-answer (a browser closed): nothing to tell the operator

        def _stream(self) -> None:
            self.send_response(200)
            self.send_header("Content-Type", "multipart/x-mixed-replace; boundary=frame")
            self.send_header("Cache-Control", "no-store")
            self.end_headers()
            seq = -1
            with frames.cond:
                frames.streams += 1
            try:
                while True:
                    seq, jpeg = frames.after(seq)
                    if not jpeg:
                        continue
                    head = f"--frame\r\nContent-Type: image/jpeg\r\nContent-Length: {len(jpeg)}\r\n\r\n".encode()
                    self.wfile.write(head + jpeg + b"\r\n")
                    self.wfile.flush()
            except (BrokenPipeError, ConnectionResetError, OSError):
                return  # the page went away: nothing else notices
            finally:
                with frames.cond:
                    frames.streams -= 1

    return Handler
