"""The review page's HTTP server: the page, the session as JSON, one episode's plot data, the player's frames and
thumbnails as JPEGs, and the edit and publish buttons as POSTs. The standard library's threading HTTP server is
enough: one person, one page, on 127.0.0.1 (another address only when asked), a few small requests at a time."""

from __future__ import annotations

import json
import re
import sys
import threading
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path

from recorder import GloverecError
from recorder.review.frames import Frames
from recorder.review.session import Session

PAGE = (Path(__file__).with_name("page.html")).read_bytes()
_FRAME = re.compile(r"^/frame/(\d+)/(\d+)\.jpg$")
_THUMB = re.compile(r"^/thumb/(\d+)\.jpg(\?.*)?$")
_EPISODE = re.compile(r"^/api/episode/(\d+)$")


class Review:
    """The server for ``session``, listening once made (a port in use is a one-line GloverecError)."""

    def __init__(self, session: Session, host: str = "127.0.0.1", port: int = 8766):
        self.session, self.frames = session, Frames(session)
        try:
            self.server = ThreadingHTTPServer((host, port), _handler(self))
        except OSError as exc:
            self.frames.close()
            raise GloverecError(
                f"cannot serve on {host}:{port} ({exc.strerror or exc}): pass another --http-port"
            ) from None
        self.server.daemon_threads = True
        self.url = f"http://{host}:{self.server.server_address[1]}/"

    def serve(self) -> None:
        """Until Ctrl-C (KeyboardInterrupt) or ``close``."""
        self.frames.warm()
        try:
            self.server.serve_forever(poll_interval=0.2)
        finally:
            self.server.server_close()
            self.frames.close()

    def start(self) -> threading.Thread:
        """Serve on a thread (tests, the benchmark)."""
        thread = threading.Thread(target=self.serve, daemon=True)
        thread.start()
        return thread

    def close(self) -> None:
        self.server.shutdown()


def _handler(review: Review):
    session, frames = review.session, review.frames

    class Handler(BaseHTTPRequestHandler):
        def log_message(self, *args) -> None:  # quiet: the URL line is what the person reads
            pass

        def do_GET(self) -> None:
            path = self.path
            try:
                if path in ("/", "/index.html"):
                    return self._send(200, "text/html; charset=utf-8", PAGE)
                if path == "/api/session":
                    with session.lock:
                        return self._json(200, session.describe())
                if m := _EPISODE.match(path):
                    return self._json(200, session.plots(int(m[1])))
                if m := _FRAME.match(path):
                    return self._send(200, "image/jpeg", frames.frame(int(m[1]), int(m[2])))
                if m := _THUMB.match(path):
                    return self._send(200, "image/jpeg", frames.thumb(int(m[1])), cache=True)
                self._send(404 if path != "/favicon.ico" else 204, "text/plain", b"")
            except GloverecError as exc:
                self._json(400, {"error": str(exc)})
            except Exception as exc:  # noqa: BLE001  (one request failed: the page says why, the server goes on)
                self._json(500, {"error": f"{type(exc).__name__}: {exc}"})

        def do_POST(self) -> None:
            try:
                body = json.loads(self.rfile.read(int(self.headers.get("Content-Length") or 0)) or b"{}")
                if self.path == "/api/edit":
                    with session.lock:
                        session.edit(int(body["episode"]), str(body["op"]), body.get("t"))
                        return self._json(200, session.describe())
                if self.path == "/api/publish":
                    with session.lock:
                        before = session.src
                        try:
                            session.publish()
                        finally:
                            if session.src != before:
                                frames.reset()
                        return self._json(200, session.describe())
                self._send(404, "text/plain", b"not found")
            except GloverecError as exc:
                self._json(400, {"error": str(exc)})
            except (KeyError, ValueError, TypeError) as exc:
                self._json(400, {"error": f"bad request: {exc}"})
            except Exception as exc:  # noqa: BLE001
                print(f"review: {self.path} failed: {type(exc).__name__}: {exc}", file=sys.stderr, flush=True)
                self._json(500, {"error": f"{type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else ''}"})

        def _json(self, code: int, obj) -> None:
            self._send(code, "application/json", json.dumps(obj).encode())

        def _send(self, code: int, kind: str, body: bytes, cache: bool = False) -> None:
            try:
                self.send_response(code)
                self.send_header("Content-Type", kind)
                self.send_header("Content-Length", str(len(body)))
                self.send_header("Cache-Control", "max-age=3600" if cache else "no-store")
                self.end_headers()
                self.wfile.write(body)
            except (BrokenPipeError, ConnectionResetError):
                pass  # the page went away mid-answer

    return Handler
