# SPDX-License-Identifier: GPL-3.0-or-later
"""Field authoring operators: Comb (modal), Source/Sink, Presets, Field from Strokes.

Each edit: mesh_io.read_field_state -> fields.* (native ray casts and relaxation) ->
mesh_io.write_field_state -> overlay refresh -> optional live re-synthesis.

With Live Update the re-synthesis starts from the edit's in-memory FieldState (mesh arrays and the
direction exactly as stored), and the field attribute writes run on the main thread while the
synthesizer works in a worker thread (see commit_edit). TEXSYNTH_LIVE_PATH=full keeps the previous
sequence (write the field, then a Synthesize that re-reads the mesh), the benchmarks' baseline;
TEXSYNTH_LIVE_PATH=sequential is the in-memory path without the worker thread.
"""
import os
import time

import bpy
import numpy as np

from .. import compat
from ..bridge import mesh_io
from ..core.layers import MeshArrays
from ..core.settings import SURFACE_METHODS, SettingsError
from . import authoring, overlay
from ..ui import operators, properties
from ..uv_methods import synthesis

# Per object name: (authoring.mesh_key, RayCaster, FieldMesh), rebuilt when the mesh changes.
_native_meshes = {}
# Preprocessed samples kept in memory for live updates: key -> Preprocessed.
_live_samples = {}
# Per object name, during a Comb session only: the snapshot of its last live update, whose buffers
# the next one reads the replaced layers into (no fresh pages per stroke).
_live_snapshots = {}
# Figures of the last edit / live update, shown by the panel and read by tests and benchmarks.
last_timings = {}
# "full": live updates take the pre-overlap path (write the field, then re-read and re-synthesize);
# "sequential": from memory, no worker thread.
LIVE_PATH_ENV = "TEXSYNTH_LIVE_PATH"


def _native_mesh(obj, arrays, which):
    key = authoring.mesh_key(arrays)
    cached = _native_meshes.get(obj.name)
    if cached is None or cached[0] != key:
        cached = [key, None, None]
        _native_meshes[obj.name] = cached
    if cached[which] is None:
        cached[which] = authoring.ray_caster(arrays) if which == 1 else authoring.field_mesh(arrays)
    return cached[which]


def caster_for(obj, arrays):
    return _native_mesh(obj, arrays, 1)


def field_mesh_for(obj, arrays):
    return _native_mesh(obj, arrays, 2)


def _active_mesh(context):
    obj = context.active_object
    if obj is None or obj.type != "MESH":
        raise SettingsError("select a mesh object first")
    if obj.data.library is not None:
        raise SettingsError("mesh %r is linked from a library and cannot be edited" % obj.data.name)
    return obj


def field_state(context, obj):
    state = mesh_io.read_field_state(obj, tuple(context.scene.texsynth.axis))
    state.field_mesh = field_mesh_for(obj, state.arrays)
    return state


PRESETS = ("AXIS", "CURVATURE", "SMOOTH")


def preset_field(obj, preset, axis, iterations=10):
    """obj's field state (read from the mesh; axis: the fallback direction) with a preset applied, not
    written yet: the Field Preset operator and the CLI's --field-preset."""
    state = mesh_io.read_field_state(obj, tuple(axis))
    state.field_mesh = field_mesh_for(obj, state.arrays)
    if preset == "AXIS":
        authoring.preset_axis(state, tuple(axis))
    elif preset == "CURVATURE":
        authoring.preset_curvature(state)
    elif preset == "SMOOTH":
        authoring.preset_smooth(state, iterations)
    else:
        raise SettingsError("unknown field preset %r (choose one of %s)" % (preset, ", ".join(PRESETS)))
    return state


def commit_edit(context, obj, state):
    """Writes the edited field, refreshes the overlay and re-synthesizes when Live Update is on.
    Returns a warning when the live update failed (the field edit itself is kept), else None."""
    attributes = mesh_io.field_attributes(obj, state)
    written = []

    def write_field():
        mesh_io.write_field_attributes(obj, attributes)
        written.append(True)

    warning = None
    if not context.scene.texsynth.field_live_update:
        write_field()
    elif os.environ.get(LIVE_PATH_ENV) == "full":
        write_field()
        try:
            live_update(context, obj)
        except (ValueError, RuntimeError) as error:
            warning = "TexSynth live update failed: %s" % error
    else:
        try:
            live_update(context, obj, state, attributes, write_field)
        except (ValueError, RuntimeError) as error:
            warning = "TexSynth live update failed: %s" % error
        if not written:  # the live update failed before the field was written: the edit is kept
            write_field()
    overlay.invalidate(obj.name)
    for area in getattr(context.screen, "areas", None) or ():
        if area.type == "VIEW_3D":
            area.tag_redraw()
    return warning


def _report_warning(operator, warning):
    if warning:
        operator.report({"WARNING"}, warning)


# Vector-field patches preview after a field edit: patch sampling into an image of at most this size
# (the analysed sample stays in memory), so combing gives feedback in a fraction of a second.
PATCH_PREVIEW_SIZE = 256


def _arrays_from_memory(obj, state, attributes):
    """MeshArrays for the synthesizer from the edit's FieldState, with the direction as a
    fresh Synthesize would read it back from the attribute (object space -> world, same float32
    rounding), or None when the mesh no longer matches the state (counts, transform or positions
    changed: the caller then re-reads everything)."""
    a, mesh = state.arrays, obj.data
    if (len(mesh.vertices), len(mesh.loops), len(mesh.polygons)) != (a.num_vertices, a.num_corners, a.num_faces):
        return None
    matrix = np.array(obj.matrix_world, dtype=np.float64)
    # 1 ms per 100k vertices: proves the positions (and transform) the state was read with still hold.
    if not np.array_equal(mesh_io.read_positions(obj, matrix), a.positions):
        return None
    direction = mesh_io.vectors_to_world(attributes[authoring.DIRECTION_NAME][1].reshape(-1, 3), matrix)
    return MeshArrays(a.positions, a.corner_verts, a.poly_starts, a.poly_sizes, direction=direction)


def live_update(context, obj, state=None, attributes=None, write_field=None):
    """Re-synthesizes obj with the sample kept in memory.

    Without state: reads the mesh and the field just written (the previous path). With the edit's
    FieldState, its field_attributes and the function that writes them (commit_edit): the jump-map
    method synthesizes from memory in a worker thread while write_field() runs on the main thread
    (write_field is called in every case, before this returns or raises, unless a settings error
    stops the update first). UV methods only rewrite the UV layers and weights (materials are left
    as they are); vector-field patches rewrite the object's image at preview size (Synthesize makes
    the full-size one)."""
    props = context.scene.texsynth
    settings = props.to_settings()
    if settings.orientation == "AXIS":
        settings.orientation, settings.direction_attribute = "FIELD", authoring.DIRECTION_NAME
    if settings.method == "PATCHES":
        if write_field is not None:
            write_field()  # the preview reads the field from the mesh
        return _patch_preview(context, obj, props, settings)
    if settings.method in SURFACE_METHODS + ("PARTICLES",):
        raise SettingsError("live update is not available for %s: press Synthesize"
                                     % props.bl_rna.properties["method"].enum_items[settings.method].name)
    settings.validate()
    sample = operators.sample_from_settings(props)
    cache_dir = properties.cache_dir(context)
    key = (sample.describe(), repr(sorted(settings.preprocess_params().items())), cache_dir)
    pre = _live_samples.get(key)
    if pre is None:
        pre = synthesis.preprocess(sample, settings, cache_dir)
        _live_samples.clear()
        _live_samples[key] = pre
    start = time.perf_counter()
    for name in [name for name in last_timings if name.startswith("live_")]:
        del last_timings[name]
    arrays = None
    if (state is not None and write_field is not None and settings.method == "JUMPMAP"
            and settings.direction_attribute == authoring.DIRECTION_NAME):
        arrays = _arrays_from_memory(obj, state, attributes)
    last_timings["live_from_memory"] = arrays is not None
    if arrays is not None:
        report = synthesis.synthesize_from_memory(obj, arrays, settings, pre, write_field,
                                                  overlap=os.environ.get(LIVE_PATH_ENV) != "sequential",
                                                  reuse_snapshot=_live_snapshots.pop(obj.name, None))
        _live_snapshots.clear()  # one object edited at a time: keep one set of buffers
        if obj.name in overlay.active_editors:  # only during a Comb session (released by its end)
            _live_snapshots[obj.name] = report.snapshot
        last_timings.update(("live_" + name, value) for name, value in report.seconds.items())
    else:
        if write_field is not None:
            write_field()
        report = synthesis.synthesize([obj], sample, settings, cache_dir, "NONE", preprocessed=pre)
    last_timings["live_update"] = time.perf_counter() - start
    last_timings["live_native"] = report.native_stats.get(obj.name, {}).get("seconds", 0.0)
    if report.failures:
        raise SettingsError(report.summary())
    return report


def _patch_preview(context, obj, props, settings):
    from ..surface_colour import synthesis as surface_synthesis
    settings.patch_mode = "SAMPLING"
    settings.validate()
    request = props.to_bake_request()
    request.size = min(int(request.size), PATCH_PREVIEW_SIZE)
    request.margin = min(int(request.margin), 4)
    start = time.perf_counter()
    report = surface_synthesis.synthesize([obj], operators.sample_from_settings(props), settings, request,
                                          props.material_mode, context=context,
                                          cache_dir=properties.cache_dir(context))
    last_timings["live_update"] = time.perf_counter() - start
    last_timings["live_native"] = report.native_stats.get(obj.name, {}).get("seconds_synthesis", 0.0)
    if report.failures:
        raise SettingsError(report.summary())
    return report


def _ray_from_event(context, event):
    """World-space (origin, direction) of the view ray under the mouse, or (None, None) when the
    mouse is not over a 3D view's main region. The operators may be started from the sidebar, so the
    region is found from the window mouse position, not taken from the context."""
    from bpy_extras import view3d_utils
    area = context.area
    if area is None or area.type != "VIEW_3D":
        return None, None
    for region in area.regions:
        if region.type != "WINDOW" or region.data is None:
            continue
        x, y = event.mouse_x - region.x, event.mouse_y - region.y
        if 0 <= x < region.width and 0 <= y < region.height:
            origin = view3d_utils.region_2d_to_origin_3d(region, region.data, (x, y))
            direction = view3d_utils.region_2d_to_vector_3d(region, region.data, (x, y))
            return np.array(origin, np.float64), np.array(direction, np.float64)
    return None, None


class TEXSYNTH_OT_comb(bpy.types.Operator):
    """Comb the direction field: drag over the surface (Ctrl-drag or Erase removes anchors; [ ] radius;
    Esc / right click to finish)"""
    bl_idname = "texsynth.comb"
    bl_label = "Comb Field"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        return (context.mode == "OBJECT" and context.area is not None and context.area.type == "VIEW_3D"
                and context.active_object is not None and context.active_object.type == "MESH")

    def invoke(self, context, event):
        try:
            self.obj = _active_mesh(context)
            self.state = field_state(context, self.obj)
            props = context.scene.texsynth
            self.brush = authoring.CombBrush(self.state, caster_for(self.obj, self.state.arrays),
                                          props.field_brush_radius, props.field_brush_strength)
        except (ValueError, RuntimeError) as error:
            self.report({"ERROR"}, str(error))
            return {"CANCELLED"}
        # Started by the Comb workspace tool's click: this press is the stroke, the release ends it.
        self.from_tool = event.type == "LEFTMOUSE" and event.value == "PRESS"
        self.dragging = False
        if self.from_tool:
            self.dragging = True
            self._dab(context, event)
        mesh_io.write_field_state(self.obj, self.state)  # the overlay needs the direction attribute
        overlay.active_editors.add(self.obj.name)
        overlay.invalidate(self.obj.name)
        context.window_manager.modal_handler_add(self)
        context.area.header_text_set("Comb: drag to paint, Ctrl-drag to erase, [ ] radius, Esc/RMB to finish")
        context.area.tag_redraw()
        return {"RUNNING_MODAL"}

    def _dab(self, context, event):
        origin, direction = _ray_from_event(context, event)
        if origin is not None:
            props = context.scene.texsynth
            self.brush.dab(origin, direction, erase_mode=event.ctrl or props.field_erase)

    def _update_cursor(self, context, event):
        origin, direction = _ray_from_event(context, event)
        surface = None if origin is None else self.brush.hit(origin, direction)
        overlay.brush_cursor = None if surface is None else (surface[0], surface[1], self.brush.radius)
        context.area.tag_redraw()

    def _finish(self, context):
        overlay.brush_cursor = None
        overlay.active_editors.discard(self.obj.name)
        _live_snapshots.pop(self.obj.name, None)
        context.area.header_text_set(None)
        context.area.tag_redraw()

    def _end_stroke(self, context):
        self.dragging = False
        start = time.perf_counter()
        if self.brush.end_stroke():
            try:
                _report_warning(self, commit_edit(context, self.obj, self.state))
            except (ValueError, RuntimeError) as error:
                self.report({"WARNING"}, str(error))
        last_timings.update(stroke_hit_testing=self.brush.seconds["hit_testing"],
                            stroke_relax=self.brush.seconds["relax"], stroke_commit=time.perf_counter() - start)
        self.brush.seconds = {"hit_testing": 0.0, "relax": 0.0}

    def modal(self, context, event):
        props = context.scene.texsynth
        if event.type in {"ESC", "RIGHTMOUSE"} and event.value == "PRESS":
            if self.dragging:
                self._end_stroke(context)
            self._finish(context)
            return {"FINISHED"}
        if event.type in {"LEFT_BRACKET", "RIGHT_BRACKET"} and event.value == "PRESS":
            props.field_brush_radius *= 0.8 if event.type == "LEFT_BRACKET" else 1.25
            self.brush.radius = props.field_brush_radius
            return {"RUNNING_MODAL"}
        if event.type == "LEFTMOUSE":
            if event.value == "PRESS":
                if _ray_from_event(context, event)[0] is None:
                    return {"PASS_THROUGH"}  # a click on the sidebar / header: let Blender handle it
                self.dragging = True
                self.brush.radius, self.brush.strength = props.field_brush_radius, props.field_brush_strength
                self._dab(context, event)
                return {"RUNNING_MODAL"}
            if event.value == "RELEASE" and self.dragging:
                self._end_stroke(context)
                if self.from_tool:
                    self._finish(context)
                    return {"FINISHED"}
                return {"RUNNING_MODAL"}
        if event.type in {"MOUSEMOVE", "INBETWEEN_MOUSEMOVE"}:
            self.brush.radius = props.field_brush_radius
            self._update_cursor(context, event)
            if self.dragging:
                self._dab(context, event)
                return {"RUNNING_MODAL"}
        return {"PASS_THROUGH"}  # navigation keeps working


class TEXSYNTH_OT_singularity(bpy.types.Operator):
    """Place or remove a source (field points away) or sink (field points toward) at the clicked
    vertex; the field is relaxed around it"""
    bl_idname = "texsynth.singularity"
    bl_label = "Source / Sink"
    bl_options = {"REGISTER", "UNDO"}

    mode: bpy.props.EnumProperty(name="Mode", items=(("SOURCE", "Source", "Field points away from here"),
                                                      ("SINK", "Sink", "Field points toward here"),
                                                      ("REMOVE", "Remove", "Remove a source or sink")),
                                 default="SOURCE")
    vertex: bpy.props.IntProperty(name="Vertex", default=-1, min=-1, options={"SKIP_SAVE"},
                                  description="Vertex index (-1: pick it with a click on the surface)")

    @classmethod
    def poll(cls, context):
        return context.mode == "OBJECT" and context.active_object is not None and context.active_object.type == "MESH"

    def invoke(self, context, event):
        """From the viewport or the sidebar: wait for a click on the surface (Esc cancels)."""
        if self.vertex >= 0 or context.area is None or context.area.type != "VIEW_3D":
            return self.execute(context)
        context.window_manager.modal_handler_add(self)
        context.window.cursor_modal_set("CROSSHAIR")
        context.area.header_text_set("%s: click on the surface (Esc / right click to cancel)" % self.mode.title())
        return {"RUNNING_MODAL"}

    def _end(self, context):
        context.window.cursor_modal_restore()
        context.area.header_text_set(None)

    def modal(self, context, event):
        if event.type in {"ESC", "RIGHTMOUSE"} and event.value == "PRESS":
            self._end(context)
            return {"CANCELLED"}
        if event.type != "LEFTMOUSE" or event.value != "PRESS":
            return {"PASS_THROUGH"}
        origin, direction = _ray_from_event(context, event)
        if origin is None:
            return {"PASS_THROUGH"}
        self._end(context)
        try:
            obj = _active_mesh(context)
            arrays = mesh_io.read_mesh(obj)
            vertex = authoring.nearest_vertex(caster_for(obj, arrays), arrays.positions, origin, direction)
        except (ValueError, RuntimeError) as error:
            self.report({"ERROR"}, str(error))
            return {"CANCELLED"}
        if vertex < 0:
            self.report({"WARNING"}, "TexSynth: click on the object's surface")
            return {"CANCELLED"}
        self.vertex = vertex
        return self.execute(context)

    def execute(self, context):
        kind = {"SOURCE": authoring.SOURCE, "SINK": authoring.SINK, "REMOVE": 0}[self.mode]
        if self.vertex < 0:
            self.report({"ERROR"}, "TexSynth: no vertex given (click on the surface, or set vertex=)")
            return {"CANCELLED"}
        try:
            obj = _active_mesh(context)
            state = field_state(context, obj)
            authoring.set_singularity(state, self.vertex, kind)
            _report_warning(self, commit_edit(context, obj, state))
        except (ValueError, RuntimeError) as error:
            self.report({"ERROR"}, str(error))
            return {"CANCELLED"}
        self.report({"INFO"}, "TexSynth: %s at vertex %d" % (self.mode.lower(), self.vertex))
        return {"FINISHED"}


class TEXSYNTH_OT_field_preset(bpy.types.Operator):
    """Set the direction field from a preset"""
    bl_idname = "texsynth.field_preset"
    bl_label = "Field Preset"
    bl_options = {"REGISTER", "UNDO"}

    preset: bpy.props.EnumProperty(
        name="Preset",
        items=(("AXIS", "Global Axis", "The panel's axis projected on the surface (clears combed anchors)"),
               ("CURVATURE", "Curvature", "Along the direction of least curvature (e.g. along tubes)"),
               ("SMOOTH", "Smooth", "Relax the current field")),
        default="AXIS")
    iterations: bpy.props.IntProperty(name="Iterations", default=10, min=1, max=1000)

    @classmethod
    def poll(cls, context):
        return context.mode == "OBJECT" and context.active_object is not None and context.active_object.type == "MESH"

    def execute(self, context):
        try:
            obj = _active_mesh(context)
            state = preset_field(obj, self.preset, context.scene.texsynth.axis, self.iterations)
            _report_warning(self, commit_edit(context, obj, state))
        except (ValueError, RuntimeError) as error:
            self.report({"ERROR"}, str(error))
            return {"CANCELLED"}
        return {"FINISHED"}


def guide_strokes(context):
    """World-space polylines of the scene's annotation strokes and of selected Grease Pencil objects."""
    annotation = compat.scene_annotation(context)
    datas = [(annotation, None)] if annotation is not None else []
    datas += [(obj.data, np.array(obj.matrix_world, np.float64)) for obj in context.selected_objects
              if obj.type in compat.GREASE_PENCIL_OBJECT_TYPES]
    strokes = []
    for data, matrix in datas:
        for points in compat.stroke_polylines(data, context.scene.frame_current):
            if matrix is not None:
                points = points @ matrix[:3, :3].T + matrix[:3, 3]
            strokes.append(points)
    return strokes


class TEXSYNTH_OT_field_from_strokes(bpy.types.Operator):
    """Turn annotation (and selected Grease Pencil) strokes drawn on the surface into field anchors"""
    bl_idname = "texsynth.field_from_strokes"
    bl_label = "Field from Strokes"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        return context.mode == "OBJECT" and context.active_object is not None and context.active_object.type == "MESH"

    def execute(self, context):
        props = context.scene.texsynth
        try:
            obj = _active_mesh(context)
            strokes = guide_strokes(context)
            if not strokes:
                raise SettingsError("no annotation or Grease Pencil strokes found: draw some on the surface")
            state = field_state(context, obj)
            used = authoring.anchors_from_strokes(state, caster_for(obj, state.arrays), strokes,
                                               props.field_brush_radius, props.field_brush_strength)
            if not used:
                raise SettingsError("no stroke point lies within the brush radius of %r" % obj.name)
            _report_warning(self, commit_edit(context, obj, state))
        except (ValueError, RuntimeError) as error:
            self.report({"ERROR"}, str(error))
            return {"CANCELLED"}
        self.report({"INFO"}, "TexSynth: %d stroke point(s) became anchors" % used)
        return {"FINISHED"}


COMB_TOOL_ID = "texsynth.comb_tool"


class TexSynthCombTool(bpy.types.WorkSpaceTool):
    """Toolbar tool: each drag is one comb stroke (Ctrl-drag erases); the field overlay is shown
    while the tool is active."""
    bl_space_type = "VIEW_3D"
    bl_context_mode = "OBJECT"
    bl_idname = COMB_TOOL_ID
    bl_label = "Comb Field"
    bl_description = "Comb the TexSynth direction field: drag over the active mesh (Ctrl-drag erases)"
    bl_icon = "ops.sculpt.border_hide"
    bl_keymap = (("texsynth.comb", {"type": "LEFTMOUSE", "value": "PRESS"}, None),
                 ("texsynth.comb", {"type": "LEFTMOUSE", "value": "PRESS", "ctrl": True}, None))

    def draw_settings(context, layout, tool):
        props = context.scene.texsynth
        layout.prop(props, "field_brush_radius")
        layout.prop(props, "field_brush_strength")
        layout.prop(props, "field_erase")


def comb_tool_active(context):
    workspace = getattr(context, "workspace", None)
    if workspace is None:
        return False
    try:
        tool = workspace.tools.from_space_view3d_mode("OBJECT", create=False)
    except (AttributeError, TypeError, RuntimeError):
        return False
    return tool is not None and tool.idname == COMB_TOOL_ID


def register_tool():
    try:
        bpy.utils.register_tool(TexSynthCombTool, separator=True)
    except (ValueError, RuntimeError, AttributeError):
        pass  # no toolbar (e.g. some background setups): the operator and panel still work


def unregister_tool():
    try:
        bpy.utils.unregister_tool(TexSynthCombTool)
    except Exception:  # noqa: BLE001 - bpy raises a bare Exception when the toolbar no longer has it
        pass  # (read_factory_settings rebuilt the toolbar before disabling add-ons)


classes = (TEXSYNTH_OT_comb, TEXSYNTH_OT_singularity, TEXSYNTH_OT_field_preset, TEXSYNTH_OT_field_from_strokes)
