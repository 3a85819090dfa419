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

Surface-colour methods (round neighbourhoods, patches) write their texels directly: bridge/images.py
write_surface_colour().

Texture particles: the background bakes as above, then each class's decals are composited over it in
texture space (particles/baking.py; Cycles' selected-to-active bake would keep one decal per ray).
"""
import dataclasses
import time

import bpy

from ..bridge import mesh_io
from ..bridge.images import TEMP_PREFIX, keep_unused, new_image, store_image, take_name
from ..bridge.uv_maps import choose_uv_map, remove_uv_map, smart_project
from ..core import bake_options as options
from ..core.names import fit_name
from ..particles import baking as particle_baking
from ..shading import blend_groups, surface_material
from ..core.bake_options import BakeError, BakeRequest  # noqa: F401  (re-exported for the operator and the CLI)


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
        if request.material != "ASSIGN":  # the image (no material) or the material not assigned is the output
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


