"""Values kept for later calls: the tables a frame repeats every frame (an OFDM schedule's cycles
ask for the same direct paths, cross-talk tables and demodulation phasors each time)."""

from __future__ import annotations


def kept(cache: dict, key, limit: int, compute):
    """``cache[key]``, computed by ``compute()`` the first time; ``cache`` is emptied before a
    new entry once it holds ``limit`` (the keys in use repeat: a few cycles of a schedule)."""
    if key not in cache:
        if len(cache) >= limit:
            cache.clear()
        cache[key] = compute()
    return cache[key]
