# SPDX-License-Identifier: GPL-3.0-or-later
"""Viewport overlay: the active object's direction field as short arrows (gpu module).

Drawn while a field tool is running (comb modal) or while "Show Field" is on; nothing otherwise.
Arrow geometry is computed in numpy (arrow_lines, bpy-free) and cached per object until the field
or the display settings change (invalidate()).
"""
import numpy as np

_handle = None
_cache = {}          # object name -> (key, batch)
active_editors = set()  # object names being edited by a modal tool
brush_cursor = None  # (centre, unit normal, radius) in world space while the comb is over the surface


def arrow_lines(positions, normals, directions, density, length, seed=0):
    """(2 * 3 * k, 3) float32 line-segment endpoints: for a deterministic subset of about
    density * N vertices, a shaft along the direction and two barbs. Positions are lifted off the
    surface by a small fraction of the length so the arrows are not hidden by the faces."""
    n = len(positions)
    if n == 0:
        return np.zeros((0, 3), np.float32)
    rng = np.random.default_rng(seed)
    chosen = np.flatnonzero(rng.random(n) < density) if density < 1.0 else np.arange(n)
    d = np.asarray(directions, np.float64)[chosen]
    keep = np.linalg.norm(d, axis=1) > 1e-6
    chosen, d = chosen[keep], d[keep]
    nrm = np.asarray(normals, np.float64)[chosen]
    base = np.asarray(positions, np.float64)[chosen] + nrm * (0.05 * length)
    tip = base + d * length
    side = np.cross(nrm, d) * (0.25 * length)
    back = d * (0.35 * length)
    segments = np.stack([base, tip, tip, tip - back + side, tip, tip - back - side], axis=1)
    return segments.reshape(-1, 3).astype(np.float32)


def circle_lines(centre, normal, radius, segments=48):
    """(2 * segments, 3) float32 line endpoints of a circle in the plane through centre with normal."""
    normal = np.asarray(normal, np.float64)
    helper = np.array([1.0, 0.0, 0.0]) if abs(normal[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    u = np.cross(normal, helper)
    u /= np.linalg.norm(u)
    v = np.cross(normal, u)
    angles = np.linspace(0.0, 2.0 * np.pi, segments + 1)
    ring = np.asarray(centre, np.float64) + radius * (np.cos(angles)[:, None] * u + np.sin(angles)[:, None] * v)
    return np.stack([ring[:-1], ring[1:]], axis=1).reshape(-1, 3).astype(np.float32)


def mean_edge_length(arrays):
    """Mean length over polygon sides (interior edges counted twice: no de-duplication pass)."""
    if arrays.num_corners == 0:
        return 1.0
    next_corner = np.arange(arrays.num_corners) + 1
    next_corner[arrays.poly_starts + arrays.poly_sizes - 1] = arrays.poly_starts
    p = arrays.positions
    return float(np.mean(np.linalg.norm(p[arrays.corner_verts] - p[arrays.corner_verts[next_corner]], axis=1)))


def invalidate(name=None):
    if name is None:
        _cache.clear()
    else:
        _cache.pop(name, None)


def _batch_for(obj, props):
    from gpu_extras.batch import batch_for_shader
    from .. import compat
    from ..bridge import mesh_io
    from . import authoring, mesh_state
    key = (props.field_arrow_density, props.field_arrow_length, len(obj.data.vertices),
           tuple(map(tuple, obj.matrix_world)))
    cached = _cache.get(obj.name)
    if cached is not None and cached[0] == key:
        return cached[1]
    direction = mesh_io.read_point_attribute(obj.data, authoring.DIRECTION_NAME, "FLOAT_VECTOR")
    if direction is None:
        _cache[obj.name] = (key, None)
        return None
    arrays = mesh_io.read_mesh(obj)
    linear = np.array(obj.matrix_world, dtype=np.float64)[:3, :3]
    world_direction = direction @ linear.T
    length = mean_edge_length(arrays) * props.field_arrow_length
    normals = mesh_state.field_mesh_for(obj, arrays).normals  # cached per mesh, shared with the tools
    lines = arrow_lines(arrays.positions, normals, world_direction, props.field_arrow_density, length)
    batch = batch_for_shader(compat.uniform_color_shader(), "LINES", {"pos": lines}) if len(lines) else None
    _cache[obj.name] = (key, batch)
    return batch


def _draw():
    import bpy
    import gpu
    from .. import compat
    context = bpy.context
    scene = getattr(context, "scene", None)
    obj = getattr(context, "active_object", None)
    if scene is None or obj is None or obj.type != "MESH" or not hasattr(scene, "texsynth"):
        return
    props = scene.texsynth
    if not (props.show_field or obj.name in active_editors or comb_tool_active(context)):
        return
    if brush_cursor is not None and obj.name in active_editors:
        _draw_brush_cursor(*brush_cursor)
    try:
        batch = _batch_for(obj, props)
    except (ValueError, RuntimeError):
        return  # a broken attribute is reported by the tools, never by the draw callback
    if batch is None:
        return
    shader = compat.uniform_color_shader()
    gpu.state.depth_test_set("LESS_EQUAL")
    gpu.state.line_width_set(1.5)
    shader.bind()
    shader.uniform_float("color", (1.0, 0.55, 0.1, 1.0))
    batch.draw(shader)
    gpu.state.depth_test_set("NONE")
    gpu.state.line_width_set(1.0)


def _draw_brush_cursor(centre, normal, radius):
    import gpu
    from gpu_extras.batch import batch_for_shader
    from .. import compat
    shader = compat.uniform_color_shader()
    lift = np.asarray(normal) * (0.01 * radius)  # just above the surface
    batch = batch_for_shader(shader, "LINES", {"pos": circle_lines(np.asarray(centre) + lift, normal, radius)})
    gpu.state.line_width_set(2.0)
    shader.bind()
    shader.uniform_float("color", (1.0, 1.0, 1.0, 0.9))
    batch.draw(shader)
    gpu.state.line_width_set(1.0)


def _on_undo_redo(*_args):
    invalidate()  # undo/redo may restore another field: rebuild the arrows


def register():
    global _handle
    import bpy
    if _handle is None and not bpy.app.background:
        _handle = bpy.types.SpaceView3D.draw_handler_add(_draw, (), "WINDOW", "POST_VIEW")
    for handlers in (bpy.app.handlers.undo_post, bpy.app.handlers.redo_post):
        if _on_undo_redo not in handlers:
            handlers.append(_on_undo_redo)


def unregister():
    global _handle
    import bpy
    if _handle is not None:
        bpy.types.SpaceView3D.draw_handler_remove(_handle, "WINDOW")
        _handle = None
    for handlers in (bpy.app.handlers.undo_post, bpy.app.handlers.redo_post):
        if _on_undo_redo in handlers:
            handlers.remove(_on_undo_redo)
    _cache.clear()
    active_editors.clear()
    global brush_cursor
    brush_cursor = None


COMB_TOOL_ID = "texsynth.comb_tool"


def comb_tool_active(context):
    workspace = getattr(context, "workspace", None)
    if workspace is None:
        return False
    try:
        tool = workspace.tools.from_space_view3d_mode("OBJECT", create=False)
    except (AttributeError, TypeError, RuntimeError):
        return False
    return tool is not None and tool.idname == COMB_TOOL_ID
