# SPDX-License-Identifier: GPL-3.0-or-later
"""What texture particles create in the .blend, all or nothing: per class a decal object (parented to the
target, UV map into the atlas, INT FACE `particle_id`) and/or a points object (loose points with
`rotation`, `scale`, `class`, and a Geometry Nodes modifier instancing the artist's collection), the atlas
image and its alpha-blended material, the analysis' segmentation preview image. Mesh data goes through
bridge/mesh_io.py; this module makes the objects, images, materials and node groups around it.

Every created object carries TAG = the target's name and CLASS_TAG = its class, so Clear and re-synthesis
find exactly what a run made.
"""
import itertools
import os
import re

import bpy
import numpy as np

from .. import compat
from ..bridge import mesh_io, sources
from ..core.names import fit_name
from ..shading import surface_material
from . import core, outputs

TAG, CLASS_TAG, KIND_TAG = "texsynth_particles", "texsynth_class", "texsynth_kind"
# For baking (particles/baking.py): the class's layer order and the target's loop-triangle count at synthesis
# (a different count: the target was edited, the source triangles no longer match).
RANK_TAG, TRIANGLES_TAG = "texsynth_rank", "texsynth_target_triangles"
# Per decal polygon its target loop triangle, per corner (b1, b2, 0) on it. A FLOAT_VECTOR, not a FLOAT2:
# Blender 3.5+ lists every FLOAT2 corner attribute as a UV map.
SOURCE_TRIANGLE_NAME, SOURCE_BARY_NAME = "TexSynth_SourceTriangle", "TexSynth_SourceBary"
STACK_LEVEL_NAME = "TexSynth_StackLevel"  # INT FACE: the decal's stacking level (a bake puts the higher on top)
ATLAS_UV = "TexSynth Atlas"
ATLAS_PREFIX, MATERIAL_PREFIX = "TexSynth Atlas: ", "TexSynth Particles: "
PREVIEW_PREFIX = "TexSynth Segmentation: "
GROUP_PREFIX = "TexSynth Instances: "
MODIFIER_NAME = "TexSynth Instances"
_TEMP = "~TexSynth new "
_temporary_numbers = itertools.count()  # background files written by this process


def decal_name(target_name, class_id):
    return fit_name("TexSynth Decals: ", target_name, " %d" % class_id)


def points_name(target_name, class_id):
    return fit_name("TexSynth Points: ", target_name, " %d" % class_id)


def _image(name, width, height, rgba_bottom_first, float_buffer, srgb=True):
    """A new packed RGBA image with these pixels (bottom row first)."""
    image = bpy.data.images.new(name, width, height, alpha=True, float_buffer=float_buffer)
    try:
        if not float_buffer:
            image.colorspace_settings.name = "sRGB" if srgb else "Non-Color"
        image.alpha_mode = "STRAIGHT"
        image.pixels.foreach_set(np.ascontiguousarray(rgba_bottom_first, dtype=np.float32).ravel())
        image.update()
        image.pack()
    except Exception:
        bpy.data.images.remove(image)
        raise
    return image


def replace_image(name, width, height, rgba_bottom_first, float_buffer=False, srgb=True):
    """A new image `name` with these pixels, taking the place of the old one of that name (its users,
    the Image Editors showing it, are remapped to the new one; the old one is removed). Never rewritten in
    place: Blender's undo does not restore the pixels of a packed image rewritten in place (3.4 to 5.2),
    while a removed image comes back whole, pixels and users."""
    image = bpy.data.images.get(name)
    new = _image(_TEMP + name, width, height, rgba_bottom_first, float_buffer, srgb)
    if image is not None:
        image.user_remap(new)
        bpy.data.images.remove(image)
    new.name = name
    return new


def segmentation_image(sample_name, preview):
    """The analysis view's image 'TexSynth Segmentation: <sample>' (class colours, particle outlines)."""
    height, width = preview.shape[:2]
    image = replace_image(fit_name(PREVIEW_PREFIX, sample_name), width, height, preview, False, True)
    image.use_fake_user = True  # shown by the panel and the Image Editor, used by nothing else
    return image


def decal_material(name, atlas):
    """Material: UV map 'TexSynth Atlas' -> Image Texture (Extension Clip, Linear) -> Principled Base Color
    and Alpha (surface_material's nodes), alpha blended in Eevee (compat); the same nodes render in Cycles."""
    material = surface_material.new_material(name, image=atlas, uv_map=ATLAS_UV)
    tree = material.node_tree
    texture = next(node for node in tree.nodes if node.bl_idname == "ShaderNodeTexImage")
    texture.extension = "CLIP"
    principled = next(node for node in tree.nodes if node.bl_idname == "ShaderNodeBsdfPrincipled")
    tree.links.new(texture.outputs["Alpha"], principled.inputs["Alpha"])
    compat.use_alpha_blend(material)
    return material


def instance_group(collection):
    """Geometry Nodes group 'TexSynth Instances: <collection>': Instance on Points picking the collection's
    child by the INT point attribute `class` (wrapping), rotated and scaled by `rotation` and `scale`."""
    name = fit_name(GROUP_PREFIX, collection.name)
    group = bpy.data.node_groups.get(name)
    if group is not None and group.bl_idname == "GeometryNodeTree":
        return group
    group = bpy.data.node_groups.new(name, "GeometryNodeTree")
    try:
        compat.ensure_group_socket(group, "Geometry", "INPUT", "NodeSocketGeometry")
        compat.ensure_group_socket(group, "Geometry", "OUTPUT", "NodeSocketGeometry")
        compat.mark_modifier_group(group)
        nodes, links = group.nodes, group.links
        group_in, group_out = nodes.new("NodeGroupInput"), nodes.new("NodeGroupOutput")
        group_in.location, group_out.location = (-600, 0), (400, 0)
        info = nodes.new("GeometryNodeCollectionInfo")
        info.location = (-350, -150)
        info.transform_space = "ORIGINAL"
        info.inputs["Collection"].default_value = collection
        info.inputs["Separate Children"].default_value = True
        info.inputs["Reset Children"].default_value = True
        instance = nodes.new("GeometryNodeInstanceOnPoints")
        instance.location = (100, 0)
        instance.inputs["Pick Instance"].default_value = True
        links.new(group_in.outputs[0], instance.inputs["Points"])
        links.new(info.outputs[0], instance.inputs["Instance"])
        for index, (attribute, data_type, socket) in enumerate((
                (core.CLASS_NAME, "INT", "Instance Index"), (core.ROTATION_NAME, "FLOAT_VECTOR", "Rotation"),
                (core.SCALE_NAME, "FLOAT_VECTOR", "Scale"))):
            named = nodes.new("GeometryNodeInputNamedAttribute")
            named.location = (-350, -350 - 150 * index)
            named.data_type = data_type
            named.inputs["Name"].default_value = attribute
            links.new(compat.named_attribute_output(named), instance.inputs[socket])
        links.new(instance.outputs[0], group_out.inputs[0])
    except Exception:
        bpy.data.node_groups.remove(group)
        raise
    return group


def _natural_key(name):
    """Blender's natural, case-insensitive name order (digits compared as numbers)."""
    return [(0, int(part), "") if part.isdigit() else (1, 0, part.lower()) for part in re.split(r"(\d+)", name)]


def instance_child_bounds(collection):
    """Each child the instance group can pick, in its order (Collection Info's separated children, sorted
    by name): an object's local bounding box (min xyz, max xyz), or None for a child collection (placed as
    it is)."""
    children = [(child.name, None) for child in collection.children]
    for obj in collection.objects:
        corners = np.array([tuple(corner) for corner in obj.bound_box], np.float64)
        children.append((obj.name, (corners.min(axis=0), corners.max(axis=0))))
    children.sort(key=lambda child: _natural_key(child[0]))
    return [bounds for _, bounds in children]


class Creation:
    """Collects every ID a run creates; undo() removes them all (newest first)."""

    def __init__(self):
        self.ids = []  # (collection name in bpy.data, ID)

    def add(self, kind, datablock):
        self.ids.append((kind, datablock))
        return datablock

    def undo(self):
        for kind, datablock in reversed(self.ids):
            try:
                getattr(bpy.data, kind).remove(datablock)
            except (ReferenceError, RuntimeError):
                pass
        self.ids = []


def _tag(obj, target, class_id, kind):
    obj[TAG] = target.name
    obj[CLASS_TAG] = int(class_id)
    obj[KIND_TAG] = kind


def _parent(obj, target, collection):
    collection.objects.link(obj)
    obj.parent = target
    obj.matrix_parent_inverse.identity()  # data in the target's space: the child moves with it


def local_points(target, world):
    """World positions -> the target's object space."""
    matrix = np.array(target.matrix_world, dtype=np.float64)
    inverse = np.linalg.inv(matrix) if abs(np.linalg.det(matrix[:3, :3])) > 1e-30 else np.eye(4)
    world = np.asarray(world, np.float64).reshape(-1, 3)
    return np.ascontiguousarray(world @ inverse[:3, :3].T + inverse[:3, 3], dtype=np.float32)


def local_frames(target, rotation_axes_x, normals, scale):
    """World frames (X axis, normal, scale) -> Euler rotation and scale in the target's object space."""
    linear = np.array(target.matrix_world, dtype=np.float64)[:3, :3]
    det = np.linalg.det(linear)
    inverse = np.linalg.inv(linear) if abs(det) > 1e-30 else np.eye(3)
    factor = abs(det) ** (1.0 / 3.0) if abs(det) > 1e-30 else 1.0
    rotation = outputs.euler_xyz(np.asarray(rotation_axes_x) @ inverse.T, np.asarray(normals) @ inverse.T)
    return rotation, np.ascontiguousarray(np.asarray(scale, np.float64) / factor, dtype=np.float32)


def _face_levels(decals):
    """Each polygon's stacking level (zeros from a decal_mesh without levels)."""
    levels = decals.get("level")
    faces = np.asarray(decals["face_particle"], np.int64)
    return np.zeros(faces.size, np.int32) if levels is None else np.asarray(levels, np.int32)[faces]


def owned_objects(target_name, kinds=("DECALS", "POINTS"), class_id=None):
    """Objects a particle run made for this target (by tag)."""
    return [obj for obj in bpy.data.objects if obj.get(TAG) == target_name and obj.get(KIND_TAG) in kinds
            and (class_id is None or obj.get(CLASS_TAG) == class_id)]


class ClassOutput:
    """What one class gives, computed off the main thread: decal geometry (decal_mesh's dict, world space)
    and/or points (world positions, box axes, normals, scale)."""

    def __init__(self, class_id, rank, count):
        self.class_id, self.rank, self.count = class_id, rank, count
        self.target_triangles = 0  # the target's loop triangles the decals' source triangles index
        self.decals = None
        self.points = None  # dict position, axis, normal, scale, particle


def write_outputs(target, outputs, atlas_pixels=None, atlas_size=None, collection=None, float_atlas=False,
                  creation=None, keep_atlas=False):
    """Creates every class's objects for `target` (atomically: on an error, everything created is removed
    and older outputs are untouched), then replaces the older outputs of the same classes. Returns the
    names of the objects made. keep_atlas: reuse the target's atlas and material when they exist at this
    size (a one-class re-run packs the same atlas: rewriting and re-packing a 4096² image costs more than
    the class's geometry)."""
    creation = creation or Creation()
    scene_collection = target.users_collection[0] if target.users_collection else bpy.context.scene.collection
    made = []
    try:
        material = None
        if any(out.decals is not None for out in outputs):
            atlas_name = fit_name(ATLAS_PREFIX, target.name)
            old_atlas = bpy.data.images.get(atlas_name)
            material = bpy.data.materials.get(fit_name(MATERIAL_PREFIX, target.name))
            reuse = keep_atlas and old_atlas is not None and material is not None and \
                tuple(old_atlas.size) == tuple(atlas_size)
            if reuse:
                atlas = old_atlas
            else:
                atlas = creation.add("images", _image(_TEMP + atlas_name, atlas_size[0], atlas_size[1], atlas_pixels,
                                                      float_atlas))
                material = creation.add("materials", decal_material(_TEMP + fit_name(MATERIAL_PREFIX, target.name), atlas))
        group = instance_group(collection) if collection is not None and any(
            out.points is not None for out in outputs) else None
        if group is not None and group.users == 0 and not group.use_fake_user:
            creation.add("node_groups", group)
        for out in outputs:
            if out.decals is not None:
                d = out.decals
                bary = np.zeros((len(d["corner_verts"]), 3), np.float32)
                bary[:, :2] = d["source_barycentric"]
                mesh = creation.add("meshes", mesh_io.new_polygon_mesh(
                    _TEMP + decal_name(target.name, out.class_id), local_points(target, d["positions"]),
                    d["loop_starts"], d["loop_totals"], d["corner_verts"], ATLAS_UV, d["corner_uvs"],
                    {core.PARTICLE_ID_NAME: d["face_particle"], SOURCE_TRIANGLE_NAME: d["source_triangle"],
                     STACK_LEVEL_NAME: _face_levels(d)},
                    {SOURCE_BARY_NAME: bary}))
                mesh.materials.append(material)
                obj = creation.add("objects", bpy.data.objects.new(mesh.name, mesh))
                _tag(obj, target, out.class_id, "DECALS")
                obj[RANK_TAG] = int(out.rank)
                obj[TRIANGLES_TAG] = int(out.target_triangles)
                _parent(obj, target, scene_collection)
                made.append((obj, decal_name(target.name, out.class_id)))
            if out.points is not None:
                p = out.points
                rotation, scale = local_frames(target, p["axis"], p["normal"], p["scale"])
                mesh = creation.add("meshes", mesh_io.new_point_mesh(
                    _TEMP + points_name(target.name, out.class_id), local_points(target, p["position"]),
                    {core.ROTATION_NAME: ("FLOAT_VECTOR", rotation), core.SCALE_NAME: ("FLOAT_VECTOR", scale),
                     core.CLASS_NAME: ("INT", np.full(len(p["position"]), out.class_id, np.int32)),
                     core.PARTICLE_ID_NAME: ("INT", np.arange(len(p["position"]), dtype=np.int32))}))
                obj = creation.add("objects", bpy.data.objects.new(mesh.name, mesh))
                _tag(obj, target, out.class_id, "POINTS")
                _parent(obj, target, scene_collection)
                modifier = obj.modifiers.new(MODIFIER_NAME, "NODES")
                modifier.node_group = group
                made.append((obj, points_name(target.name, out.class_id)))
        mesh_io.fail_point("particle_outputs")
    except Exception:
        creation.undo()
        raise
    # Everything exists: the older outputs of these classes go, the new ones take their names.
    new_objects = [obj for obj, _ in made]
    if keep_atlas:  # one class: only its outputs of the kinds made
        kinds = {obj[KIND_TAG] for obj in new_objects}
        old_objects = [old for out in outputs for old in owned_objects(target.name, kinds, out.class_id)]
    else:  # a full run replaces everything an earlier run made for this target
        old_objects = owned_objects(target.name)
    for old in old_objects:
        if old not in new_objects:
            remove_object(old)
    if material is not None:
        old_material = bpy.data.materials.get(fit_name(MATERIAL_PREFIX, target.name))
        if old_material is not None and old_material != material:
            old_material.user_remap(material)
            bpy.data.materials.remove(old_material)
        material.name = fit_name(MATERIAL_PREFIX, target.name)
        if old_atlas is not None and old_atlas != atlas:
            old_atlas.user_remap(atlas)
            bpy.data.images.remove(old_atlas)
        atlas.name = fit_name(ATLAS_PREFIX, target.name)
    for obj, name in made:
        obj.name = name
        obj.data.name = name
    return [obj.name for obj, _ in made]


def remove_object(obj):
    data = obj.data
    bpy.data.objects.remove(obj)
    if data is not None and data.users == 0:
        bpy.data.meshes.remove(data)


def clear(target_name):
    """Removes a target's decal and point objects, its atlas and material, and instance groups no longer
    used; returns the number of datablocks removed."""
    removed = 0
    groups = set()
    for obj in owned_objects(target_name):
        for modifier in obj.modifiers:
            if modifier.type == "NODES" and modifier.node_group is not None:
                groups.add(modifier.node_group.name)
        remove_object(obj)
        removed += 1
    for kind, name in (("materials", fit_name(MATERIAL_PREFIX, target_name)), ("images", fit_name(ATLAS_PREFIX, target_name))):
        datablock = getattr(bpy.data, kind).get(name)
        if datablock is not None and datablock.users == 0:
            getattr(bpy.data, kind).remove(datablock)
            removed += 1
    for name in groups:
        group = bpy.data.node_groups.get(name)
        if group is not None and group.users == 0:
            bpy.data.node_groups.remove(group)
            removed += 1
    return removed


def save_background(pixels_bottom_first, path, float_buffer=False):
    """Writes the analysis' filled background (row 0 = bottom) as a PNG through a temporary image, to a
    temporary file in the same folder renamed over `path`: a reader (another Blender sharing the cache
    folder, or a run after a crash) never sees a partial file under the final name."""
    height, width = pixels_bottom_first.shape[:2]
    rgba = np.ones((height, width, 4), np.float32)
    rgba[:, :, :3] = pixels_bottom_first[:, :, :3] if pixels_bottom_first.shape[2] >= 3 else \
        pixels_bottom_first[:, :, :1]
    folder, name = os.path.split(path)
    temporary = os.path.join(folder, ".%s.tmp.%d.%d.png" % (name, os.getpid(), next(_temporary_numbers)))
    image = bpy.data.images.new(_TEMP + "background", width, height, alpha=True, float_buffer=float_buffer)
    try:
        image.pixels.foreach_set(np.clip(rgba, 0.0, 1.0).ravel())
        image.filepath_raw = temporary
        image.file_format = "PNG"
        image.save()
        os.replace(temporary, path)
    finally:
        bpy.data.images.remove(image)
        if os.path.exists(temporary):  # the save or the rename failed
            os.remove(temporary)
    return path


def background_file_usable(path, width, height):
    """True if `path` decodes (as the background's UV method will read it) to a width x height image; a
    truncated or damaged file, or one of another size, is to be written again rather than used."""
    if not os.path.isfile(path):
        return False
    try:
        pixels = sources.decode_sample_file(path)
    except ValueError:  # SettingsError / HeaderError: a header or pixels Blender cannot read
        return False
    return pixels.shape[:2] == (height, width)
