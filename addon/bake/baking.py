# SPDX-License-Identifier: GPL-3.0-or-later
"""Bake a TexSynth result into one image through a chosen UV map (Cycles' own bake), shared by the
operator and the CLI.

UV methods (jump map, texton): every material of the object has a blend group ("TexSynth Blend: ...")
feeding the Principled Base Color. For the bake, each such material gets a temporary Emission shader fed
by the group's Color (no lighting enters) on a temporary active output, and an active Image Texture node
holding the target image; Cycles bakes EMIT through the chosen UV map with a few box-filtered samples.
Everything temporary (nodes, active node and output, render engine and sampling, selection, a UV map
made by Smart UV Project) is restored in a finally block, also when the bake fails or is cancelled; a
failed bake leaves no image or material behind.

Surface-colour methods (round neighbourhoods) write their texels directly: write_surface_colour().

Texture particles: the background bakes as above, then each class's decals are composited over it in
texture space (particles/baking.py; Cycles' selected-to-active bake would keep one decal per ray).
"""
import dataclasses
import math
import time

import bpy
import numpy as np

from .. import native
from ..bridge import mesh_io
from ..core.layers import MAX_UV_LAYERS, is_texsynth_uv_name
from ..core.names import fit_name
from ..particles import baking as particle_baking
from ..shading import blend_groups, surface_material
from . import options
from .options import BakeError, BakeRequest  # noqa: F401  (re-exported for the operator and the CLI)

TEMP_PREFIX = "TexSynth Bake Temp "


@dataclasses.dataclass
class BakeResult:
    image: object
    uv_map: str
    path: str = ""
    material: object = None
    created_uv: bool = False
    seconds: float = 0.0
    notes: list = dataclasses.field(default_factory=list)

    def summary(self, object_name):
        where = ("saved to %s" % self.path) if self.path else "packed into the .blend"
        text = "TexSynth: baked %s into %r (%dx%d, UV map %r, %s) in %.2f s" % (
            object_name, self.image.name, self.image.size[0], self.image.size[1], self.uv_map, where, self.seconds)
        if self.material is not None:
            text += "; material %r" % self.material.name
        return "; ".join([text] + self.notes)


# ---------------------------------------------------------------------------------------------
# Checks (nothing changed yet)


def texsynth_groups(obj):
    """[(material, blend group node)] for every material slot of obj; BakeError when a slot has no
    TexSynth blend group feeding a Principled Base Color (no TexSynth result to bake)."""
    found, missing = [], []
    for index, slot in enumerate(obj.material_slots):
        material = slot.material
        node = _base_colour_group(material) if material is not None else None
        if node is None:
            missing.append(material.name if material is not None else "slot %d (empty)" % (index + 1))
        elif all(material is not m for m, _ in found):
            found.append((material, node))
    if not found:
        raise BakeError("object %r has no TexSynth result to bake (run Synthesize with a material mode other "
                        "than Layers Only)" % obj.name)
    if missing:
        raise BakeError("object %r: material(s) %s show no TexSynth result (no blend group on the Base Color)"
                        % (obj.name, ", ".join(repr(m) for m in missing)))
    return found


def _base_colour_group(material):
    if not material.use_nodes or material.node_tree is None:
        return None
    for link in material.node_tree.links:
        node, socket = link.from_node, link.to_socket
        if (node.type == "GROUP" and node.node_tree is not None
                and node.node_tree.name.startswith(blend_groups.GROUP_PREFIX)
                and link.from_socket.name == "Color" and link.to_node.type == "BSDF_PRINCIPLED"
                and socket.name == "Base Color"):
            return node
    return None


def _group_images(group_nodes):
    images = set()
    for _, node in group_nodes:
        for inner in node.node_tree.nodes:
            if inner.type == "TEX_IMAGE" and inner.image is not None:
                images.add(inner.image.name)
    return images


def choose_uv_map(mesh, request):
    """(name of an existing UV map, or None when one must be created); BakeError if there is none to use."""
    names = [layer.name for layer in mesh.uv_layers]
    if request.uv_map == options.BASE_UV_NAME:
        raise BakeError(options.uv_refusal())
    if not request.auto_uv:
        if request.uv_map not in names:
            others = [n for n in names if not is_texsynth_uv_name(n)]
            raise BakeError("mesh %r has no UV map %r (its UV maps: %s)"
                            % (mesh.name, request.uv_map, ", ".join(others) or "none besides TexSynth's"))
        return request.uv_map
    others = [n for n in names if not is_texsynth_uv_name(n)]
    if others:
        active = mesh.uv_layers.active.name if mesh.uv_layers.active is not None else ""
        return active if active in others else others[0]
    if not request.create_uv:
        raise BakeError("mesh %r has no UV map besides TexSynth's (whose islands overlap): choose to create one "
                        "with Smart UV Project (operator option, CLI --bake-uv auto)" % mesh.name)
    if len(names) >= MAX_UV_LAYERS:
        raise BakeError("mesh %r already has Blender's maximum of %d UV maps" % (mesh.name, MAX_UV_LAYERS))
    return None


def check(obj, request, blend_path=""):
    """Validates everything that can be checked before changing anything; returns (target, uv map or
    None, [(material, group node)])."""
    request.validate()
    if obj is None or obj.type != "MESH":
        raise BakeError("bake needs a mesh object, got %s" % ("nothing" if obj is None else obj.type.lower()))
    mesh = obj.data
    if len(mesh.polygons) == 0:
        raise BakeError("mesh %r has no faces to bake" % mesh.name)
    if mesh.uv_layers.get(options.BASE_UV_NAME) is None:
        raise BakeError("object %r has no TexSynth result to bake (no %r UV map: run Synthesize first)"
                        % (obj.name, options.BASE_UV_NAME))
    groups = texsynth_groups(obj)
    uv_map = choose_uv_map(mesh, request)
    if uv_map is None and mesh.library is not None:
        raise BakeError("mesh %r is linked from a library: cannot add a UV map" % mesh.name)
    target = options.resolve_target(request.target, obj.name, request.save_mode, blend_path)
    if target.image_name in _group_images(groups):
        raise BakeError("cannot bake into %r: the TexSynth material itself reads that image" % target.image_name)
    return target, uv_map, groups


# ---------------------------------------------------------------------------------------------
# Smart UV Project on a new UV map (restorable)


def _read_flags(collection, name):
    values = np.empty(len(collection), dtype=bool)
    collection.foreach_get(name, values)
    return values


def _mesh_flags(mesh):
    return {(kind, flag): _read_flags(getattr(mesh, kind), flag)
            for kind in ("vertices", "edges", "polygons") for flag in ("select", "hide")}


def _set_flags(mesh, flags):
    for (kind, flag), values in flags.items():
        getattr(mesh, kind).foreach_set(flag, values)


def pack_islands(size):
    """Packs the selected faces' islands options.PACK_GAP_TEXELS apart in a size² image. Blender 3.6+
    packs by shape when asked, 30-80 s on a 75k-face mesh: bounding boxes are packed (under a second)."""
    extra = {}
    properties = bpy.ops.uv.pack_islands.get_rna_type().properties.keys()
    if "shape_method" in properties:
        extra["shape_method"] = "AABB"
    if "margin_method" in properties:
        extra["margin_method"] = "FRACTION"
    bpy.ops.uv.select_all(action="SELECT")
    bpy.ops.uv.pack_islands(rotate=True, margin=options.pack_margin(size), **extra)


def smart_project(obj, request, context):
    """Adds a UV map (Smart UV Project over all faces, hidden ones too) without changing the others, the
    active UV map or the mesh's selection and hide state; returns its name. A mesh that had no active UV
    map (no UV map at all) gets the new one as its active map: an active index of -1 next to an existing
    map stays -1 on Blender 3.4 (4.x clamps it to 0), and Cycles' bake refuses such a mesh ("No active
    UV layer found")."""
    mesh = obj.data
    flags = _mesh_flags(mesh)
    # Blender 4+ stores these flags as internal attributes, created when first written: remove the
    # ones this function created (their values were all False before) so the mesh is as it was.
    attributes_before = set(mesh.attributes.keys())
    active_index = mesh.uv_layers.active_index
    render_active = [layer.active_render for layer in mesh.uv_layers]
    layer = mesh.uv_layers.new(name=options.SMART_UV_NAME, do_init=False)
    if layer is None:
        raise BakeError("could not add a UV map to mesh %r" % mesh.name)
    name = layer.name
    mesh.uv_layers.active = layer
    try:
        for kind in ("vertices", "edges", "polygons"):
            count = len(getattr(mesh, kind))
            if flags[(kind, "hide")].any():
                getattr(mesh, kind).foreach_set("hide", np.zeros(count, bool))
            getattr(mesh, kind).foreach_set("select", np.ones(count, bool))
        with _edit_mode(obj, context):
            bpy.ops.uv.smart_project(angle_limit=math.radians(options.SMART_UV_ANGLE_DEGREES), island_margin=0.0)
            pack_islands(request.size)
    except Exception:
        remove_uv_map(mesh, name)
        raise
    finally:
        _set_flags(mesh, flags)
        for kind in ("vert", "edge", "poly"):
            for flag in ("hide", "select"):
                created = mesh.attributes.get(".%s_%s" % (flag, kind))
                if created is not None and created.name not in attributes_before:
                    mesh.attributes.remove(created)
        if active_index >= 0 or mesh.uv_layers.get(name) is None:
            mesh.uv_layers.active_index = active_index
        else:
            mesh.uv_layers.active = mesh.uv_layers[name]
        for layer, flag in zip(mesh.uv_layers, render_active):
            layer.active_render = flag
        mesh.update()
    return name


def remove_uv_map(mesh, name):
    layer = mesh.uv_layers.get(name)
    if layer is not None:
        mesh.uv_layers.remove(layer)


class _edit_mode:
    """Edit mode on obj, made the only selected, active object for one operator call: Edit Mode takes
    every selected mesh along, and Smart UV Project would re-project their UV maps too. The selection
    and the active object are restored afterwards."""

    def __init__(self, obj, context):
        self.obj, self.context = obj, context

    def __enter__(self):
        objects = self.context.view_layer.objects
        self.active = objects.active
        self.selected = [o for o in objects if o is not None and o.select_get()]
        for other in self.selected:
            if other is not self.obj:
                other.select_set(False)
        self.obj.select_set(True)
        objects.active = self.obj
        bpy.ops.object.mode_set(mode="EDIT")
        return self

    def __exit__(self, *exc):
        bpy.ops.object.mode_set(mode="OBJECT")
        objects = self.context.view_layer.objects
        if self.obj not in self.selected:
            self.obj.select_set(False)
        for other in self.selected:
            other.select_set(True)
        objects.active = self.active
        return False


# ---------------------------------------------------------------------------------------------
# Temporary state


class _SceneState:
    """Render engine, Cycles sampling and the view layer's selection, restored by restore()."""

    CYCLES = ("samples", "use_denoising", "use_adaptive_sampling", "pixel_filter_type", "filter_width")

    def __init__(self, scene, view_layer):
        self.scene, self.view_layer = scene, view_layer
        self.engine = scene.render.engine
        self.cycles = None
        self.selected = [obj for obj in view_layer.objects if obj is not None and obj.select_get()]
        self.active = view_layer.objects.active

    def use_cycles(self, samples):
        try:
            self.scene.render.engine = "CYCLES"
        except TypeError:
            raise BakeError("baking needs the Cycles render engine (enable the Cycles add-on)") from None
        cycles = self.scene.cycles
        self.cycles = {key: getattr(cycles, key) for key in self.CYCLES if hasattr(cycles, key)}
        cycles.samples = samples
        cycles.use_denoising = False
        if hasattr(cycles, "use_adaptive_sampling"):
            cycles.use_adaptive_sampling = False
        cycles.pixel_filter_type = "BOX"
        cycles.filter_width = 1.0

    def select_only(self, obj):
        for other in self.selected:
            other.select_set(False)
        obj.select_set(True)
        self.view_layer.objects.active = obj

    def restore(self):
        if self.cycles is not None:
            for key, value in self.cycles.items():
                setattr(self.scene.cycles, key, value)
        self.scene.render.engine = self.engine
        for obj in self.view_layer.objects:
            if obj is not None and obj.select_get() and obj not in self.selected:
                obj.select_set(False)
        for obj in self.selected:
            obj.select_set(True)
        self.view_layer.objects.active = self.active


class _MaterialState:
    """Temporary Emission output and active Image Texture node in one material."""

    def __init__(self, material, group_node, image):
        tree = material.node_tree
        self.tree = tree
        self.active = tree.nodes.active
        self.outputs = [(node, node.is_active_output) for node in tree.nodes if node.type == "OUTPUT_MATERIAL"]
        self.selected = [node for node in tree.nodes if node.select]
        self.added = []
        emission = self._add("ShaderNodeEmission", "Emission")
        tree.links.new(group_node.outputs["Color"], emission.inputs["Color"])
        emission.inputs["Strength"].default_value = 1.0
        output = self._add("ShaderNodeOutputMaterial", "Output")
        output.target = "ALL"
        tree.links.new(emission.outputs["Emission"], output.inputs["Surface"])
        for node, _ in self.outputs:
            node.is_active_output = False
        output.is_active_output = True
        texture = self._add("ShaderNodeTexImage", "Image")
        texture.image = image
        for node in tree.nodes:
            node.select = False
        texture.select = True
        tree.nodes.active = texture

    def _add(self, kind, label):
        node = self.tree.nodes.new(kind)
        node.name = node.label = TEMP_PREFIX + label
        self.added.append(node)
        return node

    def restore(self):
        nodes = self.tree.nodes
        for node in self.added:
            if nodes.get(node.name) is not None:
                nodes.remove(node)
        for node, flag in self.outputs:
            node.is_active_output = flag
        for node in nodes:
            node.select = node in self.selected
        nodes.active = self.active


# ---------------------------------------------------------------------------------------------
# The bake


def new_image(name, size, float_buffer):
    image = bpy.data.images.new(name, size, size, alpha=True, float_buffer=float_buffer)
    image.generated_color = (0.0, 0.0, 0.0, 0.0)
    if float_buffer:
        image.colorspace_settings.name = "Linear" if bpy.app.version < (4, 0, 0) else "Linear Rec.709"
    return image


def store_image(image, target):
    """Saves the image to target.path, or packs it into the .blend."""
    if target.path:
        image.filepath_raw = target.path
        image.file_format = target.file_format
        try:
            image.save()
        except RuntimeError as error:
            raise BakeError("could not save the baked image to %s: %s" % (target.path, str(error).strip()))
        image.filepath = target.path
        image.source = "FILE"
        image.reload()
    else:
        image.pack()


def take_name(image, name):
    """Gives image the name `name`, replacing (remapping users of) an existing image of that name."""
    old = bpy.data.images.get(name)
    if old is not None and old != image:
        old.user_remap(image)
        bpy.data.images.remove(old)
    image.name = name


def keep_unused(datablock):
    """Gives an output nothing uses yet (a baked image with no material, a baked material not assigned, a
    surface-colour image with material mode Layers Only) a fake user, so saving the .blend keeps it: a
    datablock with no user is dropped by the save, whatever the report said. Returns it."""
    if datablock is not None and datablock.users == 0:
        datablock.use_fake_user = True
    return datablock


def baked_material(obj, image, uv_map, assign):
    """Material "TexSynth Baked: <object>": UV Map -> Image Texture -> Principled Base Color."""
    material = surface_material.new_material(fit_name(options.MATERIAL_PREFIX, obj.name), image=image, uv_map=uv_map)
    if assign:
        surface_material.assign(obj, material)
    return material


def bake(obj, request, context=None, progress=None):
    """Bakes obj's TexSynth result per `request` (options.BakeRequest); returns a BakeResult. Raises
    BakeError (bad request or failed bake) after undoing everything it did."""
    started = time.perf_counter()
    context = context or bpy.context
    progress = progress or (lambda fraction, text: None)
    target, uv_map, groups = check(obj, request, bpy.data.filepath)
    scene, view_layer = context.scene, context.view_layer
    if obj.name not in view_layer.objects:
        raise BakeError("object %r is not in the active view layer" % obj.name)
    if context.mode != "OBJECT":
        raise BakeError("baking needs Object Mode")
    particles = particle_baking.prepare(obj)  # checked before anything changes
    state = _SceneState(scene, view_layer)
    materials, image, created_uv, success = [], None, None, False
    inactive_uv_index = None
    notes = []
    try:
        state.select_only(obj)
        if uv_map is None:
            progress(0.05, "TexSynth: Smart UV Project on %s" % obj.name)
            uv_map = created_uv = smart_project(obj, request, context)
            notes.append("created UV map %r with Smart UV Project (the object had none besides TexSynth's)"
                         % created_uv)
        image = new_image(TEMP_PREFIX + target.image_name, request.size, target.float_buffer)
        materials = [_MaterialState(material, node, image) for material, node in groups]
        state.use_cycles(request.samples)
        uv_layers = obj.data.uv_layers
        if uv_layers.active is None:
            # No active UV map (an index of -1, which Blender 3.4 keeps and saves): Cycles refuses to bake
            # ("No active UV layer found") even with uv_layer given, so the bake's map is active meanwhile.
            inactive_uv_index = uv_layers.active_index
            uv_layers.active = uv_layers[uv_map]
        progress(0.1, "TexSynth: baking %s (%d px, Cycles)" % (obj.name, request.size))
        try:
            bpy.ops.object.bake(type="EMIT", margin=request.margin, use_clear=True, use_selected_to_active=False,
                                target="IMAGE_TEXTURES", save_mode="INTERNAL", uv_layer=uv_map)
        except RuntimeError as error:
            raise BakeError("Cycles bake failed: %s" % " ".join(str(error).split())) from None
        for material in materials:
            material.restore()
        materials = []
        if particles is not None:
            progress(0.8, "TexSynth: compositing the particles of %s" % obj.name)
            notes.append(particle_baking.apply(particles, image, uv_map, request.margin).note())
        progress(0.9, "TexSynth: storing %s" % target.image_name)
        mesh_io.fail_point("bake")  # tests: a failure after Cycles baked must still undo everything
        store_image(image, target)
        take_name(image, target.image_name)
        material = None
        if request.material != "NONE":
            material = baked_material(obj, image, uv_map, request.material == "ASSIGN")
        keep_unused(material if material is not None else image)
        success = True
    finally:
        for material in materials:
            material.restore()
        state.restore()
        if inactive_uv_index is not None:
            obj.data.uv_layers.active_index = inactive_uv_index
        if not success:
            if image is not None:
                bpy.data.images.remove(image)
            if created_uv:
                remove_uv_map(obj.data, created_uv)
    progress(1.0, "TexSynth: baked %s" % obj.name)
    return BakeResult(image=image, uv_map=uv_map, path=target.path, material=material, created_uv=bool(created_uv),
                      seconds=time.perf_counter() - started, notes=notes)


# ---------------------------------------------------------------------------------------------
# Surface-colour methods: texels computed by TexSynth itself


def write_surface_colour(image, rgba, coverage, margin=options.DEFAULT_MARGIN):
    """Hook for methods that compute surface colour per texel (round neighbourhoods): writes `rgba`
    (float (H, W, 4), row 0 = top, linear values for float images) into the bpy image of the same size,
    after extending the covered texels (`coverage`, bool (H, W)) by `margin` pixels with
    texsynth_native.dilate_margin. Texels neither covered nor within the margin keep rgba's values."""
    rgba = np.ascontiguousarray(rgba, dtype=np.float32)
    coverage = np.ascontiguousarray(coverage, dtype=bool)
    width, height = int(image.size[0]), int(image.size[1])
    if rgba.shape != (height, width, 4) or coverage.shape != (height, width):
        raise BakeError("surface colour is %s with coverage %s; image %r is %dx%d RGBA"
                        % (rgba.shape, coverage.shape, image.name, width, height))
    if image.channels != 4:
        raise BakeError("image %r has %d channels, expected RGBA" % (image.name, image.channels))
    options.check_margin(int(margin), max(width, height))
    if margin > 0:
        module = native.require()
        if not hasattr(module, "dilate_margin"):
            raise BakeError("this texsynth_native has no dilate_margin (an older build): rebuild it")
        rgba = module.dilate_margin(rgba, coverage, int(margin))
    image.pixels.foreach_set(np.ascontiguousarray(rgba[::-1]).ravel())
    image.update()
    return image
