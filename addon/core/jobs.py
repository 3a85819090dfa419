# SPDX-License-Identifier: GPL-3.0-or-later
"""Plumbing every method's run shares, bpy-free: the cancellation error and a small in-memory cache of
expensive analyses (round-neighbourhood contexts, particle analyses) kept between runs."""
import threading


class Cancelled(RuntimeError):
    """The user cancelled the run before anything was written."""


class BoundedCache:
    """The last `capacity` values by key (most recent last), safe across the worker and main threads.
    Bounded because one value can hold hundreds of MB (a 1024² round context holds ~0.3 GB)."""

    def __init__(self, capacity=1):
        self.capacity = capacity
        self.entries = []  # [(key, value)], most recent last
        self.lock = threading.Lock()

    def get(self, key):
        with self.lock:
            for index, (k, value) in enumerate(self.entries):
                if k == key:
                    self.entries.append(self.entries.pop(index))
                    return value
        return None

    def put(self, key, value):
        with self.lock:
            self.entries = [(k, v) for k, v in self.entries if k != key][-(self.capacity - 1):] \
                if self.capacity > 1 else []
            self.entries.append((key, value))

    def clear(self):
        with self.lock:
            self.entries = []
