# SPDX-License-Identifier: GPL-3.0-or-later
"""The command line's scene: the objects to work on (a mesh file imported in place of Blender's factory
objects, or named objects of the .blend), --field-preset on them, --bake, a camera and a sun framing them, and
--render."""
import math
import os
import time

import bpy

from .. import compat
from ..bake import baking
from ..fields import mesh_state


class SceneError(ValueError):
    """A --mesh, --object or --render problem; the message says which."""


# Blender's factory scene: (name, type, location). Matched exactly so a scene someone set up is never touched.
FACTORY_OBJECTS = (("Cube", "MESH", (0.0, 0.0, 0.0)), ("Camera", "CAMERA", (7.3589, -6.9258, 4.9583)),
                   ("Light", "LIGHT", (4.0762, 1.0055, 5.9039)))


def factory_objects(scene):
    """The factory startup's Cube, Camera and Light still in place, when no .blend was opened."""
    if bpy.data.filepath:
        return []
    found = []
    for name, kind, location in FACTORY_OBJECTS:
        obj = scene.objects.get(name)
        if (obj is not None and obj.type == kind and obj.parent is None
                and all(abs(a - b) < 1e-3 for a, b in zip(obj.location, location))
                and (kind != "MESH" or (len(obj.data.vertices), len(obj.data.polygons)) == (8, 6))):
            found.append(obj)
    return found


def remove_factory_objects(scene):
    """--mesh without a .blend: the default Cube would hide the mesh and the default camera and light are
    placed for that cube, so all three go; frame_scene then adds a camera and a sun for the mesh. Returns
    whether any went."""
    found = factory_objects(scene)
    for obj in found:
        data = obj.data
        datablocks = {"MESH": bpy.data.meshes, "CAMERA": bpy.data.cameras, "LIGHT": bpy.data.lights}[obj.type]
        bpy.data.objects.remove(obj)
        if data.users == 0:
            datablocks.remove(data)
    return bool(found)


def find_objects(args):
    """The objects to work on: the meshes of --mesh's file (imported), or the --object names."""
    if args.mesh:
        if not os.path.isfile(args.mesh):
            raise SceneError("mesh file not found: %s" % args.mesh)
        replaced = remove_factory_objects(bpy.context.scene)
        try:
            objects = compat.import_mesh_file(os.path.abspath(args.mesh))
        except (RuntimeError, ValueError) as error:
            raise SceneError("could not import %s: %s" % (args.mesh, str(error).strip().splitlines()[-1]))
        if not objects:
            raise SceneError("no mesh found in %s" % args.mesh)
        if replaced:  # a .blend's own scene is only framed by --render, as before
            frame_scene(bpy.context.scene, objects)
        return objects
    objects = []
    for name in args.object:
        obj = bpy.data.objects.get(name)
        if obj is None:
            meshes = ", ".join(o.name for o in bpy.data.objects if o.type == "MESH") or "none"
            raise SceneError("no object named %r (mesh objects: %s)" % (name, meshes))
        if obj.type != "MESH":
            raise SceneError("object %r is a %s, not a mesh" % (name, obj.type.lower()))
        objects.append(obj)
    return objects


def frame_scene(scene, objects):
    """Adds a camera framing the objects and a sun when the scene has none."""
    from mathutils import Vector
    corners = [obj.matrix_world @ Vector(c) for obj in objects for c in obj.bound_box]
    low = Vector(tuple(min(c[i] for c in corners) for i in range(3)))
    high = Vector(tuple(max(c[i] for c in corners) for i in range(3)))
    center, radius = (low + high) / 2, max((high - low).length / 2, 1e-3)
    if scene.camera is None:
        data = bpy.data.cameras.new("TexSynth Camera")
        camera = bpy.data.objects.new("TexSynth Camera", data)
        scene.collection.objects.link(camera)
        direction = Vector((1.0, -1.4, 0.9)).normalized()
        distance = radius / math.sin(min(data.angle_x, data.angle_y) / 2) * 1.05
        camera.location = center + direction * distance
        camera.rotation_euler = (-direction).to_track_quat("-Z", "Y").to_euler()
        data.clip_end = max(data.clip_end, distance * 4)
        scene.camera = camera
    if not any(obj.type == "LIGHT" for obj in scene.objects):
        sun = bpy.data.objects.new("TexSynth Sun", bpy.data.lights.new("TexSynth Sun", "SUN"))
        sun.data.energy = 3.0
        sun.rotation_euler = (0.7, 0.2, 0.8)
        scene.collection.objects.link(sun)
    if scene.world is None:
        scene.world = bpy.data.worlds.new("TexSynth World")
        scene.world.color = (0.3, 0.33, 0.38)


def render(scene, objects, path, resolution):
    """--render: Eevee still of the framed objects, written to path."""
    frame_scene(scene, objects)
    compat.use_eevee(scene)
    if resolution:
        scene.render.resolution_x, scene.render.resolution_y = resolution
        scene.render.resolution_percentage = 100
    scene.render.image_settings.file_format = "PNG"
    scene.render.filepath = os.path.abspath(path)
    bpy.ops.render.render(write_still=True)
    if not os.path.isfile(scene.render.filepath):
        raise SceneError("render did not write %s" % path)


def apply_field_preset(args, objects):
    """--field-preset: the Field Preset operator's work (fields/mesh_state.py preset_field) on every object,
    written to the direction attribute the synthesis then follows."""
    for obj in objects:
        try:
            mesh_state.write_field_state(obj, mesh_state.preset_field(obj, args.field_preset.upper(), args.axis))
        except (ValueError, RuntimeError) as error:
            raise SceneError("--field-preset %s on %s: %s" % (args.field_preset, obj.name, error))


def run_bake(objects, request, stats):
    """--bake: the one object's result baked per `request` (the --bake-* options); its figures go into stats."""
    if len(objects) != 1:
        raise SceneError("--bake bakes one object; %d were imported or given" % len(objects))
    started = time.perf_counter()
    try:
        result = baking.bake(objects[0], request, bpy.context)
    except (ValueError, RuntimeError) as error:
        raise SceneError("bake: %s" % error)
    stats["seconds"]["bake"] = time.perf_counter() - started
    stats["bake"] = {"image": result.image.name, "path": result.path, "uv_map": result.uv_map,
                     "size": list(result.image.size), "created_uv": result.created_uv,
                     "material": result.material.name if result.material is not None else "",
                     "notes": list(result.notes)}
    return result.summary(objects[0].name)
