"""Per-episode statistics for lerobot, exact and cheap, and the scope in which lerobot's save uses them.

lerobot (0.4.4, and 0.6 still) estimates each episode's quantiles from 5000-bin histograms built per feature
dimension (its ``RunningQuantileStats``, made for streaming data too large for memory). A saved episode is entirely
in memory, so exact quantiles (``np.quantile``) cost a fraction of a millisecond where the histograms cost ~0.2 s
per episode for our ~130 numeric dimensions: more than recording a short episode. The result has lerobot's layout
(min, max, mean, std, count, q01 ... q99, shaped as lerobot shapes them), so its ``aggregate_stats`` and
normalisation use it unchanged. Images and videos keep lerobot's own sampled computation.

lerobot also runs ``embed_images`` (a row-by-row ``datasets.map``) on every episode, ~0.1-0.3 s, which does
nothing when no feature is stored as an image in the parquet files (state-only, or cameras as videos); and the
``datasets.Dataset`` it builds from the episode, only to write it out, fingerprints itself by pickling all of its
data (~50 ms), a cache key nobody reads: a random fingerprint is what ``datasets`` itself uses when it cannot hash.
``lerobot_save_speedups(features)`` swaps these in for the duration of a ``save_episode`` call.
"""

from __future__ import annotations

from contextlib import contextmanager

import datasets.arrow_dataset as ad
import lerobot.datasets.dataset_writer as ld  # where lerobot 0.6's save_episode finds these
import numpy as np
from datasets.fingerprint import generate_random_fingerprint
from lerobot.datasets.compute_stats import compute_episode_stats

QUANTILES = (0.01, 0.10, 0.50, 0.90, 0.99)  # lerobot's DEFAULT_QUANTILES and their keys q01 ... q99
KEYS = tuple(f"q{int(q * 100):02d}" for q in QUANTILES)


def vector_stats(data) -> dict[str, np.ndarray]:
    """Stats of one numeric feature over an episode's frames: ``data`` is (N,) or (N, D), N >= 2."""
    data = np.asarray(data)
    flat = data.reshape(len(data), -1)
    wide = flat.astype(np.float64)  # lerobot's float32 sqrt(E[x^2] - E[x]^2) cancels: 0.3 for a constant 283
    stats = {
        "min": flat.min(axis=0),
        "max": flat.max(axis=0),
        "mean": wide.mean(axis=0),
        "std": wide.std(axis=0),
        "count": np.array([len(data)]),
    }
    for key, value in zip(KEYS, np.quantile(wide, QUANTILES, axis=0)):
        stats[key] = value
    if data.ndim == 1:  # lerobot keeps the reduced axis of scalar features: shape (1,)
        stats = {k: v if k == "count" else v.reshape(1) for k, v in stats.items()}
    return stats


def episode_stats(episode_data: dict, features: dict, quantile_list=None) -> dict:
    """Drop-in for lerobot's ``compute_episode_stats``: exact for numeric features of two or more frames."""

    exact, rest = {}, {}
    for key, data in episode_data.items():
        dtype = features[key]["dtype"]
        if dtype == "string":
            continue
        if dtype in ("image", "video") or len(data) < 2 or quantile_list not in (None, list(QUANTILES)):
            rest[key] = data
        else:
            exact[key] = vector_stats(data)
    if rest:
        exact.update(compute_episode_stats(rest, features, quantile_list))
    return exact


@contextmanager
def lerobot_save_speedups(features: dict):
    """Within this scope lerobot's ``save_episode`` uses ``episode_stats`` and, when no feature is an image
    stored in the parquet files, skips ``embed_images``."""

    saved = ld.compute_episode_stats, ld.embed_images, ad.generate_fingerprint
    ld.compute_episode_stats = episode_stats
    ad.generate_fingerprint = lambda dataset: generate_random_fingerprint()
    if not any(ft["dtype"] == "image" for ft in features.values()):
        ld.embed_images = lambda dataset: dataset
    try:
        yield
    finally:
        ld.compute_episode_stats, ld.embed_images, ad.generate_fingerprint = saved
