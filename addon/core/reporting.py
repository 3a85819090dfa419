# SPDX-License-Identifier: GPL-3.0-or-later
"""Timings per phase and the report of one run (shown by the operator, written by the CLI); bpy-free."""
import dataclasses
import time


class Timings:
    """Accumulates wall-clock seconds per phase: `with timings.phase("synthesis"): ...`.
    transfer = read + write (bpy mesh I/O)."""
    PHASES = ("preprocess", "read", "synthesis", "write", "material")

    def __init__(self):
        self.seconds = {name: 0.0 for name in self.PHASES}
        self._start = time.perf_counter()

    def phase(self, name):
        timings = self

        class _Phase:
            def __enter__(self):
                self.start = time.perf_counter()

            def __exit__(self, *exc):
                timings.seconds[name] = timings.seconds.get(name, 0.0) + time.perf_counter() - self.start
                return False
        return _Phase()

    def as_dict(self):
        result = dict(self.seconds)
        result["transfer"] = result["read"] + result["write"]
        result["total"] = time.perf_counter() - self._start
        return result


@dataclasses.dataclass
class Report:
    """What one run did and could not do (shown by the operator, written by the CLI)."""
    objects: list = dataclasses.field(default_factory=list)     # names written
    failures: list = dataclasses.field(default_factory=list)    # (name, message)
    faces: int = 0
    vertices: int = 0
    corners: int = 0
    cache_hit: bool = False
    cache_status: str = ""
    native_stats: dict = dataclasses.field(default_factory=dict)  # per object name
    seconds: dict = dataclasses.field(default_factory=dict)
    blend_mode: str = ""   # the shader's blend mode actually used
    blend_reason: str = ""  # why Auto chose it
    notes: list = dataclasses.field(default_factory=list)       # warnings that did not stop the run
    outputs: list = dataclasses.field(default_factory=list)     # what was made (images, attributes)
    uses_cache: bool = True  # surface-colour methods use the sample directly (no preprocessing cache)

    def add_object(self, name, mesh_arrays, stats):
        self.objects.append(name)
        self.faces += mesh_arrays.num_faces
        self.vertices += mesh_arrays.num_vertices
        self.corners += mesh_arrays.num_corners
        self.native_stats[name] = dict(stats or {})

    def summary(self):
        if not self.objects and self.failures:
            return "TexSynth: nothing written; " + "; ".join("%s: %s" % f for f in self.failures)
        total = self.seconds.get("total", 0.0)
        text = "TexSynth: %d object(s), %d faces in %.2f s" % (len(self.objects), self.faces, total)
        if self.uses_cache:
            text += " (cache %s)" % ("hit" if self.cache_hit else "miss")
        if self.blend_reason:
            text += "; %s blending (%s)" % (self.blend_mode.lower(), self.blend_reason)
        if self.outputs or self.notes:
            text += "; " + "; ".join(self.outputs + self.notes)
        if self.failures:
            text += "; %d failed: %s" % (len(self.failures), "; ".join("%s: %s" % f for f in self.failures))
        return text

    def as_json(self):
        return {
            "objects": list(self.objects),
            "failures": [{"object": name, "error": message} for name, message in self.failures],
            "faces": self.faces, "vertices": self.vertices, "corners": self.corners,
            "cache_hit": bool(self.cache_hit), "cache_status": self.cache_status,
            "seconds": dict(self.seconds), "native": self.native_stats,
            "blend_mode": self.blend_mode, "blend_reason": self.blend_reason, "notes": list(self.notes),
            "outputs": list(self.outputs),
        }
