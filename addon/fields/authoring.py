# SPDX-License-Identifier: GPL-3.0-or-later
"""bpy-free core of field authoring: comb brush, sources/sinks, presets, strokes, scale.

Model (all stored as POINT attributes on the mesh by mesh_io.py, vectors in object space there and
in world space here):
  TexSynth_Guide        FLOAT_VECTOR  the artist's anchors (comb, strokes, presets); zero = unset
  TexSynth_Singularity  INT           +1 source, -1 sink, 0 none
  TexSynth_Direction    FLOAT_VECTOR  the full field = relax(guide, singularities, axis); what
                                      Synthesize reads (orientation "Direction Attribute")
  TexSynth_Scale        FLOAT         texture density multiplier (Blender Mapping-node sense:
                                      2 = features half as large)
Every edit changes guide/singularities, then `relax` recomputes the direction natively
(texsynth_native.compute_field: anchors held, transported and smoothed; sources/sinks honoured).
"""
import dataclasses
import time
import zlib

import numpy as np

from .. import native

DIRECTION_NAME = "TexSynth_Direction"
GUIDE_NAME = "TexSynth_Guide"
SINGULARITY_NAME = "TexSynth_Singularity"
SCALE_NAME = "TexSynth_Scale"
SOURCE, SINK = 1, -1


@dataclasses.dataclass
class FieldState:
    """One mesh's field data in world space (arrays: core.layers.MeshArrays)."""
    arrays: object
    guide: np.ndarray          # (N, 3) float32, zero rows unset
    singularity: np.ndarray    # (N,) int32
    direction: np.ndarray      # (N, 3) float32 unit tangent vectors
    axis: tuple = (0.0, 0.0, 1.0)
    normals: np.ndarray = None  # (N, 3) float32, computed on demand
    field_mesh: object = None   # texsynth_native.FieldMesh of arrays (optional: reused by relax)

    def vertex_normals(self):
        if self.normals is None:
            self.normals = (np.asarray(self.field_mesh.normals, np.float32) if self.field_mesh is not None
                            else vertex_normals(self.arrays))
        return self.normals


def mesh_key(arrays):
    """Changes whenever positions or topology change (the ray caster must then be rebuilt)."""
    crc = 0
    for array in (arrays.positions, arrays.corner_verts, arrays.poly_starts, arrays.poly_sizes):
        crc = zlib.crc32(np.ascontiguousarray(array).view(np.uint8), crc)
    return (arrays.num_vertices, arrays.num_corners, arrays.num_faces, crc)


def ray_caster(arrays):
    return native.require().RayCaster(arrays.positions, arrays.corner_verts, arrays.poly_starts, arrays.poly_sizes)


def field_mesh(arrays):
    """A native FieldMesh (adjacency built once) for repeated relaxations of this mesh."""
    return native.require().FieldMesh(arrays.positions, arrays.corner_verts, arrays.poly_starts, arrays.poly_sizes)


def vertex_normals(arrays):
    """(N, 3) float32 unit vertex normals, the same the native field and synthesis use."""
    return np.asarray(native.require().vertex_normals(arrays.positions, arrays.corner_verts, arrays.poly_starts,
                                                      arrays.poly_sizes), dtype=np.float32)


def edges(arrays):
    """(E, 2) int32 undirected polygon edges (each once)."""
    next_corner = np.arange(arrays.num_corners) + 1
    last = arrays.poly_starts + arrays.poly_sizes - 1
    next_corner[last] = arrays.poly_starts
    pairs = np.stack([arrays.corner_verts, arrays.corner_verts[next_corner]], axis=1)
    pairs.sort(axis=1)
    pairs = pairs[pairs[:, 0] != pairs[:, 1]]
    return np.unique(pairs, axis=0).astype(np.int32)


def tangent_unit(vectors, normals):
    """Vectors projected onto the tangent planes and normalised; rows that vanish become zero."""
    projected = vectors - normals * np.sum(vectors * normals, axis=1, keepdims=True)
    length = np.linalg.norm(projected, axis=1, keepdims=True)
    ok = length[:, 0] > 1e-6 * np.maximum(np.linalg.norm(vectors, axis=1), 1e-30)
    out = np.zeros_like(projected, dtype=np.float32)
    out[ok] = projected[ok] / length[ok]
    return out


def falloff(distances, radius):
    """Smooth brush falloff: 1 at the centre, 0 at the radius, (1 - (d/r)^2)^2."""
    t = np.clip(np.asarray(distances, dtype=np.float64) / max(float(radius), 1e-30), 0.0, 1.0)
    return (1.0 - t * t) ** 2


def relax(state):
    """Recomputes state.direction from the guide and singularities (native); returns it."""
    module = native.require()
    a = state.arrays
    sources = np.flatnonzero(state.singularity == SOURCE).astype(np.int32)
    sinks = np.flatnonzero(state.singularity == SINK).astype(np.int32)
    kwargs = dict(orientation="field", axis=tuple(float(c) for c in state.axis),
                  direction=np.ascontiguousarray(state.guide, dtype=np.float32), sources=sources, sinks=sinks)
    if state.field_mesh is not None:
        field = state.field_mesh.compute_field(**kwargs)
    else:
        field = module.compute_field(a.positions, a.corner_verts, a.poly_starts, a.poly_sizes, **kwargs)
    state.direction = np.asarray(field, dtype=np.float32)
    return state.direction


def paint(state, ids, weights, stroke_direction):
    """Comb: vertices `ids` become anchors along the stroke direction (projected on each tangent
    plane). Existing anchors blend toward it by `weights` in (0, 1] (the falloff); vertices that
    were not anchors take the stroke direction outright, so a first stroke steers the whole
    relaxed field instead of pinning the old field at the brush rim."""
    if len(ids) == 0:
        return
    normals = state.vertex_normals()[ids]
    anchored = np.any(state.guide[ids] != 0, axis=1, keepdims=True)
    current = state.guide[ids]
    stroke = tangent_unit(np.broadcast_to(np.asarray(stroke_direction, dtype=np.float32), normals.shape), normals)
    w = np.where(anchored, np.asarray(weights, dtype=np.float32)[:, None], 1.0)
    blended = tangent_unit(current * (1.0 - w) + stroke * w, normals)
    keep = np.any(blended != 0, axis=1)
    state.guide[ids[keep]] = blended[keep]


def erase(state, ids):
    state.guide[ids] = 0.0


class CombBrush:
    """One comb session on a mesh: rays in (from the viewport or a test), guide edits out.
    A stroke is a sequence of dabs; the direction of a dab is the motion of the brush on the surface
    since the previous dab. `end_stroke` relaxes the field (the painted vertices are anchors)."""

    def __init__(self, state, caster, radius, strength=1.0):
        self.state, self.caster = state, caster
        self.radius, self.strength = float(radius), float(strength)
        self.last_point = None
        self.painted = 0
        self.seconds = {"hit_testing": 0.0, "relax": 0.0}

    def hit(self, origin, direction):
        """(world-space hit point, interpolated unit normal) of one ray, or None."""
        hits = self.caster.cast(np.asarray([origin], dtype=np.float32), np.asarray([direction], dtype=np.float32))
        if hits["face"][0] < 0:
            return None
        point = np.asarray(origin, dtype=np.float64) + float(hits["distance"][0]) * np.asarray(direction, dtype=np.float64)
        normal = hits["barycentrics"][0] @ self.state.vertex_normals()[hits["vertices"][0]].astype(np.float64)
        length = np.linalg.norm(normal)
        return point, (normal / length if length > 1e-12 else np.array([0.0, 0.0, 1.0]))

    def dab(self, origin, direction, erase_mode=False):
        """Applies the brush where the ray hits; returns the hit point (None = missed)."""
        start = time.perf_counter()
        surface = self.hit(origin, direction)
        if surface is None:
            self.seconds["hit_testing"] += time.perf_counter() - start
            return None
        point = surface[0]
        ids, distances = self.caster.vertices_within(point, self.radius)
        # Only the side facing the ray: never paint through thin walls.
        facing = np.sum(self.state.vertex_normals()[ids] * np.asarray(direction, dtype=np.float32), axis=1) < 0
        ids, distances = ids[facing], distances[facing]
        self.seconds["hit_testing"] += time.perf_counter() - start
        weights = self.strength * falloff(distances, self.radius)
        ids, weights = ids[weights > 0], weights[weights > 0]
        if erase_mode:
            erase(self.state, ids)
            self.painted += len(ids)
            self.last_point = point
            return point
        if self.last_point is not None:
            motion = point - self.last_point
            if np.linalg.norm(motion) < 0.05 * self.radius:
                return point  # too short to define a direction; keep the previous anchor point
            paint(self.state, ids, weights, motion)
            self.painted += len(ids)
        self.last_point = point
        return point

    def end_stroke(self):
        """Relaxes the field after a stroke; returns True if anything changed."""
        self.last_point = None
        if not self.painted:
            return False
        start = time.perf_counter()
        relax(self.state)
        self.seconds["relax"] += time.perf_counter() - start
        self.painted = 0
        return True


def nearest_vertex(caster, positions, origin, direction):
    """The vertex of the hit triangle closest to the hit point, or -1 on a miss."""
    hits = caster.cast(np.asarray([origin], dtype=np.float32), np.asarray([direction], dtype=np.float32))
    if hits["face"][0] < 0:
        return -1
    return int(hits["vertices"][0][int(np.argmax(hits["barycentrics"][0]))])


def set_singularity(state, vertex, kind):
    """kind: SOURCE, SINK or 0 (remove). Raises ValueError for a bad vertex or kind."""
    if kind not in (SOURCE, SINK, 0):
        raise ValueError("singularity kind must be +1 (source), -1 (sink) or 0 (remove), got %r" % (kind,))
    if not 0 <= int(vertex) < state.arrays.num_vertices:
        raise ValueError("vertex %r is not in the mesh (%d vertices)" % (vertex, state.arrays.num_vertices))
    state.singularity[int(vertex)] = kind
    relax(state)


def preset_axis(state, axis):
    """The global axis everywhere (guide cleared; sources/sinks kept)."""
    axis = np.asarray(axis, dtype=np.float64)
    if axis.shape != (3,) or not np.all(np.isfinite(axis)) or np.linalg.norm(axis) < 1e-12:
        raise ValueError("axis must be a finite non-zero 3D vector, got %r" % (tuple(axis),))
    state.axis = tuple(float(c) for c in axis)
    state.guide[:] = 0.0
    return relax(state)


def preset_curvature(state, smoothing_rings=2, anisotropy_threshold=0.2):
    """Guide = directions of least curvature where defined; relaxed elsewhere."""
    a = state.arrays
    directions, _ = native.require().principal_curvature_directions(
        a.positions, a.corner_verts, a.poly_starts, a.poly_sizes, smoothing_rings=int(smoothing_rings),
        anisotropy_threshold=float(anisotropy_threshold))
    state.guide[:] = directions
    return relax(state)


def preset_smooth(state, iterations=10):
    """Relaxes the current field: Jacobi-averages the direction over edges (nothing held), then
    the anchors take the smoothed values and the field is relaxed from them again."""
    if not 0 <= int(iterations) <= 10000:
        raise ValueError("iterations must be in [0, 10000], got %r" % (iterations,))
    e = edges(state.arrays)
    normals = state.vertex_normals()
    field = state.direction.astype(np.float64)
    n = state.arrays.num_vertices
    for _ in range(int(iterations)):
        summed = field.copy()
        for axis in range(3):
            summed[:, axis] += np.bincount(e[:, 0], field[e[:, 1], axis], minlength=n)
            summed[:, axis] += np.bincount(e[:, 1], field[e[:, 0], axis], minlength=n)
        smoothed = tangent_unit(summed, normals)
        vanished = ~np.any(smoothed != 0, axis=1)
        smoothed[vanished] = field[vanished]
        field = smoothed.astype(np.float64)
    anchored = np.any(state.guide != 0, axis=1)
    state.guide[anchored] = field[anchored]
    return relax(state)


def stroke_tangents(points):
    """(k, 3) central-difference tangents of a polyline (one-sided at the ends)."""
    points = np.asarray(points, dtype=np.float64)
    if len(points) < 2:
        return np.zeros_like(points)
    tangents = np.empty_like(points)
    tangents[1:-1] = points[2:] - points[:-2]
    tangents[0] = points[1] - points[0]
    tangents[-1] = points[-1] - points[-2]
    return tangents


def anchors_from_strokes(state, caster, strokes, radius, strength=1.0):
    """Guide strokes (world-space polylines drawn on or near the surface) -> anchors: every stroke
    point paints the vertices within `radius` along the stroke tangent (brush falloff). Returns the
    number of stroke points that reached the surface; relaxes when any did."""
    used = 0
    for points in strokes:
        points = np.asarray(points, dtype=np.float64)
        if points.ndim != 2 or points.shape[1] != 3 or len(points) < 2 or not np.all(np.isfinite(points)):
            continue
        for point, tangent in zip(points, stroke_tangents(points)):
            if np.linalg.norm(tangent) < 1e-12:
                continue
            ids, distances = caster.vertices_within(point, radius)
            if len(ids) == 0:
                continue
            weights = strength * falloff(distances, radius)
            keep = weights > 0
            paint(state, ids[keep], weights[keep], tangent)
            used += 1
    if used:
        relax(state)
    return used


def scale_from_weights(weights, low, high):
    """Vertex-group weights in [0, 1] -> density multipliers low + w (high - low), both > 0."""
    if not (np.isfinite(low) and np.isfinite(high) and low > 0 and high > 0):
        raise ValueError("scale range must be two positive numbers, got (%r, %r)" % (low, high))
    w = np.clip(np.asarray(weights, dtype=np.float64), 0.0, 1.0)
    return (low + w * (high - low)).astype(np.float32)


def check_scale_multiplier(values, name):
    values = np.asarray(values, dtype=np.float32)
    bad = ~(np.isfinite(values) & (values > 0))
    if np.any(bad):
        raise ValueError("scale %s must be finite and > 0 everywhere; vertex %d has %r"
                         % (name, int(np.flatnonzero(bad)[0]), float(values[np.flatnonzero(bad)[0]])))
    return np.ascontiguousarray(values)
