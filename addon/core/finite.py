# SPDX-License-Identifier: GPL-3.0-or-later
"""NaN/inf checks on large result arrays without temporaries the size of the array (bpy-free)."""
import threading

import numpy as np


def all_finite(array):
    """True if no NaN/inf, in one pass with no temporary the size of the array (np.isfinite would
    allocate one: hundreds of MB of fresh pages on big meshes). NaN and inf survive a sum, so a
    finite sum proves every value finite; only a sum that overflowed from finite values (never
    for UVs and weights) needs the exact min/max scan."""
    if array.size == 0:
        return True
    with np.errstate(over="ignore", invalid="ignore"):  # an inf or NaN sum is an answer, not a warning
        if np.isfinite(np.add.reduce(array, axis=None)):
            return True
    return bool(np.isfinite(array.min()) and np.isfinite(array.max()))


class FiniteScan:
    """all_finite over named arrays in a worker thread: numpy reductions release the GIL, so the scan
    (hundreds of MB on a million-face mesh) runs while the main thread writes the layers. The arrays
    must not change until wait() returns; wait() gives the first array that is not finite, or None."""

    def __init__(self, named_arrays):
        self.bad = None
        self.error = None
        self.thread = threading.Thread(target=self._run, args=(list(named_arrays),), name="TexSynth finite scan",
                                       daemon=True)
        self.thread.start()

    def _run(self, named_arrays):
        try:
            for name, array in named_arrays:
                if not all_finite(array):
                    self.bad = name
                    return
        except BaseException as error:  # re-raised by wait() on the caller's thread
            self.error = error

    def wait(self):
        self.thread.join()
        if self.error is not None:
            raise self.error
        return self.bad
