# SPDX-License-Identifier: GPL-3.0-or-later
"""ALL bpy mesh I/O of the add-on: foreach_get/foreach_set on contiguous numpy arrays of matching
dtypes, no per-element Python loops.

Reads the object's BASE mesh (modifiers are not applied) and sends world-space positions, so the
native `scale` is texels per world unit and several objects match. Writes the UV layers and the
weight attribute on the base mesh too: corner UV layers flow through modifiers such as Subdivision,
Mirror or Array, so the modified result is textured consistently.

Writes are atomic: everything is computed and validated first; if a write still fails, every layer
created is removed and every layer overwritten is restored, leaving the mesh byte-identical.
"""
import os

import bpy
import numpy as np

from ..core.finite import all_finite
from ..core.layers import MeshArrays
from ..core.sample_image import blender_pixels_to_image
from ..core.settings import SettingsError

# Test hook: TEXSYNTH_TEST_FAIL_AT=<point> makes the write fail at that point (uv_layer, sets,
# weights, extras, material) so the tests can prove a failure mid-write leaves the mesh byte-identical.
FAIL_AT_ENV = "TEXSYNTH_TEST_FAIL_AT"


def fail_point(name):
    if os.environ.get(FAIL_AT_ENV) == name:
        raise RuntimeError("injected failure at %r (%s)" % (name, FAIL_AT_ENV))


# "before": write_result scans the results for NaN/inf before writing anything (the previous order;
# the benchmark's baseline) instead of in a worker thread while the layers are written.
WRITE_CHECK_ENV = "TEXSYNTH_WRITE_CHECK"


class MeshWriteError(RuntimeError):
    """Writing failed; the mesh has been restored."""


# Blender before 3.6 stores corner vertices and polygon offsets as unsigned ints (MLoop, MPoly):
# foreach_get copies them in one block only into a uint32 buffer; an int32 buffer takes the
# per-item path, 20-40x slower (0.23 s vs 0.01 s for 3.4M corners). Later versions store int32.
INDEX_READ_DTYPE = np.uint32 if bpy.app.version < (3, 6, 0) else np.int32


def read_indices(collection, name, count):
    """An index property of every item as int32 (a uint32 buffer viewed as int32, no copy: a value
    above 2**31 - 1 turns negative and the native validation refuses it)."""
    values = np.empty(count, dtype=INDEX_READ_DTYPE)
    collection.foreach_get(name, values)
    return values.view(np.int32)


def _buffer(size, reuse):
    """A float32 buffer of `size` values: `reuse` when it fits (a live update reads the layers it
    replaces into the previous update's snapshot buffers: no fresh pages, no page faults), else new."""
    if reuse is not None and reuse.dtype == np.float32 and reuse.size == size and reuse.flags.c_contiguous:
        return reuse
    return np.empty(size, dtype=np.float32)


def read_uv(layer, num_corners, reuse=None):
    """A UV map's (u, v) per corner, flat float32 (into `reuse` when it fits)."""
    values = _buffer(num_corners * 2, reuse)
    layer.data.foreach_get("uv", values)
    return values


def snapshot_attribute(attribute, reuse=None):
    """(data type, domain, foreach key, flat float32 values) of an attribute, to put it back exactly."""
    is_color = attribute.data_type in ("FLOAT_COLOR", "BYTE_COLOR")
    values = _buffer(len(attribute.data) * (4 if is_color else 1), reuse)
    key = "color" if is_color else "value"
    attribute.data.foreach_get(key, values)
    return (attribute.data_type, attribute.domain, key, values)


def read_mesh(obj, direction_attribute=""):
    """MeshArrays of obj's base mesh in world space (positions transformed by matrix_world)."""
    mesh = obj.data
    num_corners, num_polys = len(mesh.loops), len(mesh.polygons)
    corner_verts = read_indices(mesh.loops, "vertex_index", num_corners)
    poly_starts = read_indices(mesh.polygons, "loop_start", num_polys)
    poly_sizes = read_indices(mesh.polygons, "loop_total", num_polys)
    matrix = np.array(obj.matrix_world, dtype=np.float64)
    arrays = MeshArrays(read_positions(obj, matrix), corner_verts, poly_starts, poly_sizes)
    if direction_attribute:
        arrays.direction = read_direction(obj, direction_attribute, matrix)
    return arrays


def read_positions(obj, matrix=None):
    """(N, 3) float32 world-space vertex positions of obj's base mesh (what read_mesh sends)."""
    mesh = obj.data
    local = np.empty(len(mesh.vertices) * 3, dtype=np.float32)
    mesh.vertices.foreach_get("co", local)
    if matrix is None:
        matrix = np.array(obj.matrix_world, dtype=np.float64)
    positions = local.reshape(-1, 3)
    if not np.array_equal(matrix, np.eye(4)):
        positions = (positions @ matrix[:3, :3].T.astype(np.float32)) + matrix[:3, 3].astype(np.float32)
    return np.ascontiguousarray(positions, dtype=np.float32)


def vectors_to_world(vectors, matrix):
    """Object-space (N, 3) float32 vectors rotated to world space exactly as read_direction does, so a
    live update from memory sends the synthesizer the same bits a fresh Synthesize reads back."""
    return np.ascontiguousarray(vectors @ matrix[:3, :3].T.astype(np.float32), dtype=np.float32)


def read_direction(obj, name, matrix=None):
    """A per-vertex FLOAT_VECTOR attribute rotated to world space, or None if the mesh lacks it."""
    attribute = obj.data.attributes.get(name)
    if attribute is None:
        return None
    if attribute.domain != "POINT" or attribute.data_type != "FLOAT_VECTOR":
        raise SettingsError("attribute %r must be a vertex (point) vector attribute, it is %s on %s"
                                     % (name, attribute.data_type, attribute.domain))
    vectors = np.empty(len(obj.data.vertices) * 3, dtype=np.float32)
    attribute.data.foreach_get("vector", vectors)
    vectors = vectors.reshape(-1, 3)
    if not np.all(np.isfinite(vectors)):
        raise SettingsError("attribute %r contains NaN or infinite vectors" % name)
    if matrix is None:
        matrix = np.array(obj.matrix_world, dtype=np.float64)
    return vectors_to_world(vectors, matrix)


def read_image_pixels(image):
    """A bpy image (file, generated or packed) as float32 H x W x C, row 0 = top."""
    width, height = int(image.size[0]), int(image.size[1])  # reading the size loads file/packed buffers
    if width == 0 or height == 0 or not image.has_data:
        raise SettingsError("image %r could not be loaded (missing or unreadable file?)" % image.name)
    channels = int(image.channels)
    pixels = np.empty(width * height * channels, dtype=np.float32)
    image.pixels.foreach_get(pixels)
    return blender_pixels_to_image(pixels, width, height, channels)


# ---------------------------------------------------------------------------------------------
# Field attributes (authoring.py): vectors are object space on the mesh, world space in FieldState.

_POINT_KEYS = {"FLOAT_VECTOR": ("vector", 3, np.float32), "FLOAT": ("value", 1, np.float32),
               "INT": ("value", 1, np.int32)}


def read_point_attribute(mesh, name, data_type):
    """A POINT attribute as (N,) or (N, 3) numpy, or None when missing. SettingsError on a wrong
    domain/type or non-finite values."""
    attribute = mesh.attributes.get(name)
    if attribute is None:
        return None
    if attribute.domain != "POINT" or attribute.data_type != data_type:
        raise SettingsError("attribute %r must be a vertex (point) %s attribute, it is %s on %s"
                                     % (name, data_type, attribute.data_type, attribute.domain))
    key, width, dtype = _POINT_KEYS[data_type]
    values = np.empty(len(mesh.vertices) * width, dtype=dtype)
    attribute.data.foreach_get(key, values)
    if dtype == np.float32 and not np.all(np.isfinite(values)):
        raise SettingsError("attribute %r contains NaN or infinite values" % name)
    return values.reshape(-1, 3) if width == 3 else values


def write_point_attribute(mesh, name, data_type, values):
    """Creates or replaces a POINT attribute (a same-named attribute of another type is replaced)."""
    key, width, dtype = _POINT_KEYS[data_type]
    values = np.ascontiguousarray(values, dtype=dtype).ravel()
    if values.size != len(mesh.vertices) * width:
        raise SettingsError("attribute %r needs %d values, got %d" % (name, len(mesh.vertices) * width, values.size))
    attribute = mesh.attributes.get(name)
    if attribute is not None and (attribute.domain != "POINT" or attribute.data_type != data_type):
        mesh.attributes.remove(attribute)
        attribute = None
    if attribute is None:
        attribute = mesh.attributes.new(name, data_type, "POINT")
    attribute.data.foreach_set(key, values)


def read_vertex_group(obj, name):
    """Per-vertex weights of vertex group `name` (0 where a vertex is not in it).
    Blender has no bulk accessor for group weights: one pass over the vertices' group lists."""
    group = obj.vertex_groups.get(name)
    if group is None:
        raise SettingsError("object %r has no vertex group %r" % (obj.name, name))
    index = group.index
    weights = np.zeros(len(obj.data.vertices), dtype=np.float32)
    for vertex in obj.data.vertices:
        for element in vertex.groups:
            if element.group == index:
                weights[vertex.index] = element.weight
                break
    return weights


# ---------------------------------------------------------------------------------------------
# Surface-colour methods (surface_colour/): loop triangles with a UV map's corners, colour attributes


def read_loop_triangles(obj, uv_map=""):
    """(triangles (T, 3) int32 vertex indices, corner_uvs (T, 3, 2) float32 or None) of obj's base mesh:
    Blender's own triangulation (n-gons included), UVs of `uv_map` per triangle corner when named."""
    mesh = obj.data
    mesh.calc_loop_triangles()
    count = len(mesh.loop_triangles)
    triangles = read_indices(mesh.loop_triangles, "vertices", count * 3).reshape(count, 3)
    if not uv_map:
        return np.ascontiguousarray(triangles), None
    layer = mesh.uv_layers.get(uv_map)
    if layer is None:
        raise SettingsError("mesh %r has no UV map %r" % (mesh.name, uv_map))
    loops = read_indices(mesh.loop_triangles, "loops", count * 3)
    corner_uv = read_uv(layer, len(mesh.loops)).reshape(-1, 2)
    uvs = corner_uv[loops].reshape(count, 3, 2)
    if not all_finite(uvs):
        raise SettingsError("UV map %r of mesh %r contains NaN or infinite coordinates" % (uv_map, mesh.name))
    return np.ascontiguousarray(triangles), np.ascontiguousarray(uvs, dtype=np.float32)


def write_colour_attribute(mesh, name, rgba):
    """Writes a FLOAT_COLOR point attribute (created or replaced) and makes it the active colour
    attribute; returns an undo function that puts the mesh back as it was."""
    rgba = np.ascontiguousarray(rgba, dtype=np.float32).ravel()
    if rgba.size != len(mesh.vertices) * 4 or not all_finite(rgba):
        raise SettingsError("colour attribute %r needs %d finite values, got %d"
                                     % (name, len(mesh.vertices) * 4, rgba.size))
    old = mesh.attributes.get(name)
    saved = snapshot_attribute(old) if old is not None else None
    active = getattr(mesh.attributes, "active_color", None)
    active_name = active.name if active is not None else None

    def undo():
        attribute = mesh.attributes.get(name)
        if attribute is not None:
            mesh.attributes.remove(attribute)
        if saved is not None:
            data_type, domain, key, values = saved
            mesh.attributes.new(name, data_type, domain).data.foreach_set(key, values)
        if active_name is not None and mesh.attributes.get(active_name) is not None:
            mesh.attributes.active_color = mesh.attributes[active_name]
        mesh.update()

    try:
        if old is not None and (old.domain != "POINT" or old.data_type != "FLOAT_COLOR"):
            mesh.attributes.remove(old)
            old = None
        attribute = old or mesh.attributes.new(name, "FLOAT_COLOR", "POINT")
        attribute.data.foreach_set("color", rgba)
        fail_point("colour_attribute")
        if hasattr(mesh.attributes, "active_color"):
            mesh.attributes.active_color = mesh.attributes[name]
        mesh.update()
    except Exception as error:
        undo()
        raise MeshWriteError("writing colour attribute %r failed (mesh restored): %s" % (name, error)) from error
    return undo


# ---------------------------------------------------------------------------------------------
# Texture particles (particles/): per-triangle overrides, decal and point meshes built in bulk


def read_triangle_polygons(obj):
    """Polygon index of every loop triangle of obj's base mesh (same order as read_loop_triangles)."""
    mesh = obj.data
    mesh.calc_loop_triangles()
    return read_indices(mesh.loop_triangles, "polygon_index", len(mesh.loop_triangles))


def read_face_values(obj, name, triangles, triangle_polygons):
    """Per-triangle float values named `name`: a FLOAT FACE attribute (the triangle's polygon), a FLOAT
    POINT attribute or a vertex group (mean of the triangle's three vertices). SettingsError when the mesh
    has none of these or values are not finite and >= 0."""
    mesh = obj.data
    attribute = mesh.attributes.get(name)
    if attribute is not None and attribute.data_type == "FLOAT" and attribute.domain in ("FACE", "POINT"):
        values = np.empty(len(attribute.data), dtype=np.float32)
        attribute.data.foreach_get("value", values)
        values = values[triangle_polygons] if attribute.domain == "FACE" else values[triangles].mean(axis=1)
    elif attribute is not None:
        raise SettingsError("attribute %r must be a FLOAT face or vertex attribute, it is %s on %s"
                                     % (name, attribute.data_type, attribute.domain))
    elif obj.vertex_groups.get(name) is not None:
        values = read_vertex_group(obj, name)[triangles].mean(axis=1)
    else:
        raise SettingsError("object %r has no face attribute or vertex group %r" % (obj.name, name))
    values = np.ascontiguousarray(values, dtype=np.float32)
    if not all_finite(values) or (values.size and values.min() < 0.0):
        raise SettingsError("override %r must hold finite values >= 0" % name)
    return values


def check_polygons(num_vertices, loop_starts, loop_totals, corner_verts):
    """Blender-layout polygons that Blender can take as they are (mesh.validate costs seconds on decal meshes
    of 100k faces): contiguous corners, at least 3 per polygon, vertex indices in range."""
    starts, totals = np.asarray(loop_starts, np.int64), np.asarray(loop_totals, np.int64)
    corners = np.asarray(corner_verts, np.int64)
    if starts.shape != totals.shape or (totals.size and totals.min() < 3) or \
            not np.array_equal(starts, np.concatenate([[0], np.cumsum(totals)[:-1]])[:starts.size]) or \
            int(totals.sum()) != corners.size or (corners.size and (corners.min() < 0 or corners.max() >= num_vertices)):
        raise SettingsError("decal geometry is inconsistent (polygon offsets, sizes or vertex indices)")


def new_polygon_mesh(name, positions, loop_starts, loop_totals, corner_verts, uv_name="", corner_uvs=None,
                     face_ints=None, corner_vectors=None):
    """A new mesh from Blender-layout arrays (positions (P, 3) in the object's space), with an optional UV
    map, INT FACE attributes {name: (F,) int32} and FLOAT_VECTOR CORNER attributes {name: (C, 3) float32};
    removed again if anything fails."""
    check_polygons(len(positions), loop_starts, loop_totals, corner_verts)
    mesh = bpy.data.meshes.new(name)
    try:
        mesh.vertices.add(len(positions))
        mesh.vertices.foreach_set("co", np.ascontiguousarray(positions, dtype=np.float32).ravel())
        # Blender's own index type (uint32 before 3.6): foreach_set then copies in one block (checked >= 0 above).
        mesh.loops.add(len(corner_verts))
        mesh.loops.foreach_set("vertex_index", np.ascontiguousarray(corner_verts, dtype=INDEX_READ_DTYPE))
        mesh.polygons.add(len(loop_starts))
        mesh.polygons.foreach_set("loop_start", np.ascontiguousarray(loop_starts, dtype=INDEX_READ_DTYPE))
        mesh.polygons.foreach_set("loop_total", np.ascontiguousarray(loop_totals, dtype=INDEX_READ_DTYPE))
        if uv_name:
            layer = mesh.uv_layers.new(name=uv_name, do_init=False)
            layer.data.foreach_set("uv", np.ascontiguousarray(corner_uvs, dtype=np.float32).ravel())
        for attribute_name, values in (face_ints or {}).items():
            mesh.attributes.new(attribute_name, "INT", "FACE").data.foreach_set(
                "value", np.ascontiguousarray(values, dtype=np.int32))
        for attribute_name, values in (corner_vectors or {}).items():
            mesh.attributes.new(attribute_name, "FLOAT_VECTOR", "CORNER").data.foreach_set(
                "vector", np.ascontiguousarray(values, dtype=np.float32).ravel())
        polygons_smooth = np.ones(len(loop_starts), dtype=bool)
        mesh.polygons.foreach_set("use_smooth", polygons_smooth)
        fail_point("decal_mesh")
        mesh.update(calc_edges=True)
    except Exception:
        bpy.data.meshes.remove(mesh)
        raise
    return mesh


def new_point_mesh(name, positions, attributes):
    """A mesh of loose points with POINT attributes {name: (data_type, values)}, data_type INT, FLOAT or
    FLOAT_VECTOR; removed again if anything fails."""
    mesh = bpy.data.meshes.new(name)
    try:
        mesh.vertices.add(len(positions))
        mesh.vertices.foreach_set("co", np.ascontiguousarray(positions, dtype=np.float32).ravel())
        for attribute_name, (data_type, values) in attributes.items():
            key, width, dtype = _POINT_KEYS[data_type]
            mesh.attributes.new(attribute_name, data_type, "POINT").data.foreach_set(
                key, np.ascontiguousarray(values, dtype=dtype).ravel())
        fail_point("point_mesh")
        mesh.update()
    except Exception:
        bpy.data.meshes.remove(mesh)
        raise
    return mesh


def read_face_ints(mesh, name):
    """An INT FACE attribute as (F,) int32 (tests, re-synthesis)."""
    attribute = mesh.attributes[name]
    values = np.empty(len(attribute.data), dtype=np.int32)
    attribute.data.foreach_get("value", values)
    return values


def read_polygon_layout(mesh):
    """(loop_starts (F,), loop_totals (F,)) as int32."""
    starts = read_indices(mesh.polygons, "loop_start", len(mesh.polygons)).astype(np.int32)
    totals = read_indices(mesh.polygons, "loop_total", len(mesh.polygons)).astype(np.int32)
    return starts, totals


def read_corner_attribute(mesh, name, data_type):
    """A CORNER attribute (FLOAT2 / FLOAT_VECTOR as (C, 2) / (C, 3) float32) or the UV map `name` (FLOAT2),
    or None when missing or of another type."""
    width = {"FLOAT2": 2, "FLOAT_VECTOR": 3}[data_type]
    attribute = mesh.attributes.get(name)
    if attribute is None or attribute.domain != "CORNER" or attribute.data_type != data_type:
        layer = mesh.uv_layers.get(name) if data_type == "FLOAT2" else None
        return None if layer is None else read_uv(layer, len(mesh.loops)).reshape(-1, 2)
    values = np.empty(len(mesh.loops) * width, dtype=np.float32)
    attribute.data.foreach_get("vector", values)
    return values.reshape(-1, width)
