# SPDX-License-Identifier: GPL-3.0-or-later
"""Field authoring operators: Comb (modal) and its toolbar tool, Source/Sink, Presets, Field from Strokes.


Each edit: mesh_state.field_state -> fields.authoring (native ray casts and relaxation) ->
field_edits.commit_edit (write the field, refresh the overlay, optional live re-synthesis).
"""
import time

import bpy
import numpy as np

from .. import compat
from ..bridge import mesh_io
from ..core.settings import SettingsError
from ..fields import authoring, mesh_state, overlay
from ..fields.overlay import COMB_TOOL_ID
from . import field_edits
from .field_edits import commit_edit


def _active_mesh(context):
    obj = context.active_object
    if obj is None or obj.type != "MESH":
        raise SettingsError("select a mesh object first")
    if obj.data.library is not None:
        raise SettingsError("mesh %r is linked from a library and cannot be edited" % obj.data.name)
    return obj


def _report_warning(operator, warning):
    if warning:
        operator.report({"WARNING"}, warning)


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
            self.state = mesh_state.field_state(context, self.obj)
            props = context.scene.texsynth
            self.brush = authoring.CombBrush(self.state, mesh_state.caster_for(self.obj, self.state.arrays),
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
        mesh_state.write_field_state(self.obj, self.state)  # the overlay needs the direction attribute
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
        field_edits.release_live_buffers(self.obj.name)
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
        field_edits.last_timings.update(stroke_hit_testing=self.brush.seconds["hit_testing"],
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
            vertex = authoring.nearest_vertex(mesh_state.caster_for(obj, arrays), arrays.positions, origin, direction)
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
            state = mesh_state.field_state(context, obj)
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
            state = mesh_state.preset_field(obj, self.preset, context.scene.texsynth.axis, self.iterations)
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
            state = mesh_state.field_state(context, obj)
            used = authoring.anchors_from_strokes(state, mesh_state.caster_for(obj, state.arrays), strokes,
                                               props.field_brush_radius, props.field_brush_strength)
            if not used:
                raise SettingsError("no stroke point lies within the brush radius of %r" % obj.name)
            _report_warning(self, commit_edit(context, obj, state))
        except (ValueError, RuntimeError) as error:
            self.report({"ERROR"}, str(error))
            return {"CANCELLED"}
        self.report({"INFO"}, "TexSynth: %d stroke point(s) became anchors" % used)
        return {"FINISHED"}


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
