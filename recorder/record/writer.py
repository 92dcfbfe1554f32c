"""Saving episodes in a second process, so that the recording loop never waits for lerobot.

Writing an episode (lerobot's ``save_episode``: parquet files, stats, metadata, video encoding; then our
snapshot publish with its fsyncs) takes 0.1-0.5 s. In real time that would stretch the reset period; faster
than real time it would halve the throughput. So the recorder forks a writer process as soon as the
EpisodeStore exists (before any thread or device is opened): the recorder keeps filling episode buffers with
lerobot's ``add_frame`` and hands each finished buffer over a pipe; the writer saves and publishes them, in
order, and reports each index back. "episode N saved" is printed only once the writer has published it.

Crash safety is the store's: the dataset root only ever points at complete snapshots. If the recorder is
killed, the writer still saves every episode already handed to it, then sees the pipe close and exits; Ctrl-C
reaches the recorder only (the writer ignores SIGINT), which then waits for the writer to finish.
"""

from __future__ import annotations

import multiprocessing as mp
import os
import signal

import numpy as np

from recorder import GloverecError

MEDIA = ("image", "video")
FILLED_AT_SAVE = ("index", "episode_index", "task_index")


def _serve(store, conn, parent_end) -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    os.environ.setdefault("SVT_LOG", "1")  # the AV1 encoder's banner on every episode: errors only
    parent_end.close()
    while True:
        try:
            job = conn.recv()
        except (EOFError, OSError):
            return  # the recorder is gone and everything it sent has been saved
        if job is None:
            return
        episode, sidecar = job
        try:
            index = store.save_episode(sidecar, episode)
            reply = ("saved", index, sidecar)
        except Exception as exc:  # reported to the recorder, which stops with a one-line error
            reply = ("error", episode.get("episode_index"), f"{type(exc).__name__}: {exc}")
        try:
            conn.send(reply)
        except (BrokenPipeError, OSError):
            pass  # nobody listens any more; keep saving what was sent
        if reply[0] == "error":
            return


def _compact(episode: dict, features: dict) -> dict:
    """One array per numeric feature instead of one small array per frame: cheaper to pickle."""
    out = dict(episode)
    for key, ft in features.items():
        if key in FILLED_AT_SAVE or ft["dtype"] in MEDIA or not isinstance(out.get(key), list) or not out[key]:
            continue
        out[key] = np.stack(out[key])
    return out


class EpisodeWriter:
    """The writer process of one recording session (see the module docstring)."""

    def __init__(self, store):
        ctx = mp.get_context("fork")  # inherits the open store; forked before the recorder starts any thread
        self._features = store.dataset.features
        self._conn, child = ctx.Pipe()
        self._proc = ctx.Process(target=_serve, args=(store, child, self._conn), name="gloverec-writer")
        self._proc.start()
        child.close()
        store.write_images_beside()  # here, not in the fork: threads that encode camera frames beside the loop
        self.pending = 0
        self.submitted = 0  # episodes handed over in this session

    def submit(self, episode: dict, sidecar: dict) -> None:
        try:
            self._conn.send((_compact(episode, self._features), sidecar))
        except (BrokenPipeError, OSError):
            self._died()
        self.pending += 1
        self.submitted += 1

    def results(self, wait: bool = False) -> list[tuple[int, dict]]:
        """(index, sidecar) of the episodes saved since the last call; ``wait``: until none is pending."""
        out = []
        while self.pending and self._conn.poll(None if wait else 0):
            try:
                reply = self._conn.recv()
            except (EOFError, OSError):
                self._died()
            self.pending -= 1
            if reply[0] == "error":
                self.pending = 0
                raise GloverecError(f"saving episode {reply[1]} failed: {reply[2]}")
            out.append((reply[1], reply[2]))
        return out

    def close(self) -> list[tuple[int, dict]]:
        """Wait for every episode handed over; returns the last ones saved."""
        try:
            done = self.results(wait=True)
        finally:
            try:
                self._conn.send(None)
            except (BrokenPipeError, OSError):
                pass
            self._proc.join(timeout=30)
            self._conn.close()
        return done

    def _died(self):
        self.pending = 0
        raise GloverecError(
            f"the episode writer process died (exit code {self._proc.exitcode}); the episodes saved so far are intact"
        )
