# SPDX-License-Identifier: GPL-3.0-or-later
"""Shader side: the node group "TexSynth Blend: <image>" that cross-fades the blend sets, and materials using it.

Per pixel the group reads the blend sets' coordinates (corner attributes TexSynth_Sets01/23, two sets
each), their weights (TexSynth_Weights: RGB = w0..w2, A = 1 - w3) and the base UV map TexSynth, whose
weight is 1 - sum(w) (so a mesh without weights shows the base mapping alone). Three blend modes:

  LINEAR     sum_k w_k C_k. Averages in face middles lose contrast (ghosting).
  VARIANCE   (sum_k w_k C_k - mu) / sqrt(sum_k w_k^2) + mu, mu = the image's mean colour: the blend keeps
             the variance of one look-up (Heitz & Neyret 2018, Eq. 6), so contrast does not drop.
  HISTOGRAM  the same operator on a Gaussianized copy of the image (mu = 0.5), then each channel back
             through the inverse look-up table: the blend keeps the sample's histogram, not just its variance.

The same nodes run in Eevee and Cycles on every supported Blender. One group per (image, mode); normal
maps always use VARIANCE around the map's mean vector, then Blender's Normal Map node renormalises
(the histogram transform remaps X, Y, Z independently, which the Normal Map encoding does not survive).
"""
import dataclasses
import math

import bpy

from . import compat, pipeline

GROUP_PREFIX = "TexSynth Blend: "
MATERIAL_PREFIX = "TexSynth: "
NODE_PREFIX = "TexSynth "
TARGETS = ("Base Color", "Roughness", "Metallic", "Normal")  # Principled inputs named alike in 3.x and 4.x
BLEND_MODES = ("HISTOGRAM", "VARIANCE", "LINEAR")  # resolved modes (pipeline.Settings also has AUTO)
MODE_SUFFIX = {"HISTOGRAM": "", "VARIANCE": " (variance)", "LINEAR": " (linear)"}


@dataclasses.dataclass
class BlendInputs:
    """What a blend group needs besides the image."""
    mode: str = "LINEAR"
    mean: tuple = (0.5, 0.5, 0.5)  # VARIANCE: the image's mean colour as the shader reads it (linear)
    gaussian: object = None         # HISTOGRAM: bpy image, Gaussianized sample (Non-Color, channel packed)
    inverse_lut: object = None      # HISTOGRAM: bpy image, lut_size x 1, entry i for value (i + 0.5) / lut_size
    # 0: the sets' weights sum to 1 (jump map). > 0 (texton): each polygon shows its own patch (base UV)
    # in its middle and fades to the vertex mappings within this distance of its edges, in units of
    # the barycentric-like weights (see texton_synth.hpp).
    patch_zone: float = 0.0
    # VARIANCE / HISTOGRAM: the looked-up image's correlation length (texels) and size. Two mappings
    # a distance d apart are correlated ~1 / (1 + d^2 / (2 l^2)) (identical where the method continued
    # one patch): the blend is normalised by the mixture's actual standard deviation,
    # sqrt(sum_ij w_i w_j rho_ij), not by sqrt(sum w^2), which would over-sharpen such areas.
    correlation_length: float = 1.0
    size: tuple = (1, 1)

    def check(self):
        if self.mode not in BLEND_MODES:
            raise ValueError("unknown blend mode %r (choose one of %s)" % (self.mode, ", ".join(BLEND_MODES)))
        if self.mode == "HISTOGRAM" and (self.gaussian is None or self.inverse_lut is None):
            raise ValueError("histogram-preserving blending needs the Gaussianized image and its look-up table")
        return self


def blend_inputs(blend, image, method="JUMPMAP"):
    """BlendInputs for pipeline.BlendShading `blend` of `image` (loads the histogram images)."""
    inputs = BlendInputs(mode=blend.mode, mean=blend.mean, correlation_length=blend.correlation_length,
                         size=(int(image.size[0]), int(image.size[1])),
                         patch_zone=pipeline.TEXTON_PATCH_ZONE if method == "TEXTON" else 0.0)
    if blend.files is not None:
        inputs.gaussian, inputs.inverse_lut = histogram_images(blend.files, image)
    return inputs


def histogram_images(files, image):
    """(Gaussianized image, inverse look-up table) as bpy images for pipeline.HistogramFiles `files`,
    packed into the .blend so it renders anywhere. The table holds the sample's own values, so it is
    read in the sample's colour space; the Gaussianized image is data."""
    loaded = []
    for path, kind, colorspace in ((files.gaussian_path, "Gaussian", "Non-Color"),
                                   (files.lut_path, "LUT", image.colorspace_settings.name)):
        name = "TexSynth %s: %s" % (kind, image.name)
        found = bpy.data.images.get(name)
        if found is None or bpy.path.abspath(found.filepath) != path:
            if found is not None:
                bpy.data.images.remove(found)
            found = bpy.data.images.load(path, check_existing=False)
            found.name = name
        found.colorspace_settings.name = colorspace
        found.alpha_mode = "CHANNEL_PACKED"  # colour and alpha are independent values here
        if found.packed_file is None:
            found.pack()
        loaded.append(found)
    return tuple(loaded)


def group_name(image, mode="HISTOGRAM", patch_zone=0.0):
    return GROUP_PREFIX + image.name + MODE_SUFFIX[mode] + (" [patches]" if patch_zone > 0 else "")


class _Builder:
    """Adds nodes and links to one node tree; numbers become constant inputs."""

    def __init__(self, tree):
        self.nodes, self.links = tree.nodes, tree.links

    def node(self, kind, x, y, **props):
        new = self.nodes.new(kind)
        new.location = (x, y)
        for key, value in props.items():
            setattr(new, key, value)
        return new

    def connect(self, node, inputs):
        for index, value in inputs:
            if value is None:
                continue
            if isinstance(value, (int, float, tuple)):
                node.inputs[index].default_value = value
            else:
                self.links.new(value, node.inputs[index])
        return node

    def math(self, operation, a, b=None, x=0, y=0, clamp=False):
        op = self.node("ShaderNodeMath", x, y, operation=operation, use_clamp=clamp)
        return self.connect(op, ((0, a), (1, b))).outputs[0]

    def vector(self, operation, a, b=None, x=0, y=0, scale=None):
        op = self.node("ShaderNodeVectorMath", x, y, operation=operation)
        self.connect(op, ((0, a), (1, b), (3, scale)))
        return op.outputs["Vector"]

    def combine(self, x_value, y_value, z_value=0.0, x=0, y=0):
        op = self.node("ShaderNodeCombineXYZ", x, y)
        return self.connect(op, ((0, x_value), (1, y_value), (2, z_value))).outputs[0]

    def separate(self, vector, x=0, y=0):
        op = self.node("ShaderNodeSeparateXYZ", x, y)
        self.links.new(vector, op.inputs[0])
        return list(op.outputs)

    def attribute(self, name, x, y):
        return self.node("ShaderNodeAttribute", x, y, attribute_type="GEOMETRY", attribute_name=name)

    def texture(self, image, vector, x, y):
        texture = self.node("ShaderNodeTexImage", x, y, image=image, interpolation="Linear", extension="EXTEND")
        self.links.new(vector, texture.inputs["Vector"])
        return texture


def _blend_terms(b, patch_zone):
    """[(uv socket, weight socket)] for the 4 blend sets and the base mapping (last)."""
    weights = b.attribute(pipeline.WEIGHTS_NAME, -1600, 600)
    w0, w1, w2 = b.separate(weights.outputs["Vector"], -1400, 600)
    # Alpha stores 1 - w3 (see pipeline.weights_rgba): a missing attribute reads (0,0,0,1) = no weights.
    w3 = b.math("SUBTRACT", 1.0, weights.outputs["Alpha"], -1400, 450)
    set_uvs = []
    for index, name in enumerate(pipeline.SET_ATTRIBUTE_NAMES):
        y = 200 - 300 * index
        sets = b.attribute(name, -1600, y)
        # Vector = (u_a, v_a, u_b): an Image Texture reads x, y only; set b is (z, alpha).
        set_uvs.append(sets.outputs["Vector"])
        z = b.separate(sets.outputs["Vector"], -1400, y)[2]
        set_uvs.append(b.combine(z, sets.outputs["Alpha"], 0.0, -1200, y))
    weights = [w0, w1, w2, w3]
    base_uv = b.node("ShaderNodeUVMap", -1600, -500, uv_map=pipeline.BASE_UV_NAME).outputs["UV"]
    if patch_zone <= 0:
        total = b.math("ADD", b.math("ADD", w0, w1, -1200, 700), b.math("ADD", w2, w3, -1200, 550), -1000, 650)
        base_weight = b.math("SUBTRACT", 1.0, total, -800, 650, clamp=True)
        return list(zip(set_uvs, weights)) + [(base_uv, base_weight)]
    # Distance from the polygon's edges: 1 - max(w_a + w_b) over its edges; the channel pairs
    # (0,1) (1,2) (2,3) (3,0) are a quad's edges, (0,1) (1,3) (3,0) a triangle's, and none is (0, 2),
    # the diagonal Blender splits quads along. An unblended polygon (no weights) is at distance 1.
    nearest = None
    for k, (i, j) in enumerate(((0, 1), (1, 2), (2, 3), (3, 0), (1, 3))):
        pair = b.math("ADD", weights[i], weights[j], -1200, 900 + 60 * k)
        nearest = pair if nearest is None else b.math("MAXIMUM", nearest, pair, -1050, 900 + 60 * k)
    distance = b.math("SUBTRACT", 1.0, nearest, -900, 900)
    fade = b.node("ShaderNodeMapRange", -750, 900, interpolation_type="SMOOTHSTEP", clamp=True)
    b.connect(fade, ((0, distance), (1, 0.0), (2, float(patch_zone)), (3, 0.0), (4, 1.0)))
    base_weight = fade.outputs[0]
    rest = b.math("SUBTRACT", 1.0, base_weight, -600, 900)
    scaled = [b.math("MULTIPLY", w, rest, -450, 900 - 60 * k) for k, w in enumerate(weights)]
    return list(zip(set_uvs, scaled)) + [(base_uv, base_weight)]


def _mixture_variance(b, terms, inputs):
    """sum_i w_i^2 + 2 sum_{i<j} w_i w_j rho_ij with rho_ij = 1 / (1 + d_ij^2 / (2 l^2)), d_ij the texel
    distance between the mappings' coordinates (identical mappings: fully correlated; far apart:
    independent). A Cauchy-shaped falloff, not the Gaussian: 5 nodes per pair instead of 7 (measured
    render cost). The base mapping (last term) weighs 1 - sum(w) = 0 wherever the sets have weights,
    so it only enters as w_base^2 (1 on meshes without TexSynth weights)."""
    width, height = inputs.size
    factor = 1.0 / (math.sqrt(2.0) * max(float(inputs.correlation_length), 1e-3))
    sets = terms[:-1]
    # Coordinates in units of sqrt(2) l (z dropped: set attributes carry another set there).
    scaled = [b.vector("MULTIPLY", uv, (width * factor, height * factor, 0.0), x=-1000, y=-900 - 60 * k)
              for k, (uv, _) in enumerate(sets)]
    total = None
    for i, (_, w_i) in enumerate(terms):
        square = b.math("MULTIPLY", w_i, w_i, -800, -900 - 60 * i)
        total = square if total is None else b.math("ADD", total, square, -650, -900 - 60 * i)
    for i in range(len(sets)):
        for j in range(i + 1, len(sets)):
            y = -1300 - 60 * (i * len(sets) + j)
            distance = b.node("ShaderNodeVectorMath", -850, y, operation="DISTANCE")
            b.links.new(scaled[i], distance.inputs[0])
            b.links.new(scaled[j], distance.inputs[1])
            d = distance.outputs["Value"]
            falloff = b.connect(b.node("ShaderNodeMath", -700, y, operation="MULTIPLY_ADD"), ((0, d), (1, d), (2, 1.0)))
            pair = b.math("DIVIDE", b.math("MULTIPLY", sets[i][1], sets[j][1], -550, y - 30), falloff.outputs[0], -400, y)
            total = b.connect(b.node("ShaderNodeMath", -250, y, operation="MULTIPLY_ADD"),
                              ((0, pair), (1, 2.0), (2, total))).outputs[0]
    return total


def _build(group, image, inputs):
    b = _Builder(group)
    terms = _blend_terms(b, inputs.patch_zone)
    looked_up = inputs.gaussian if inputs.mode == "HISTOGRAM" else image
    color = alpha = None
    for k, (uv, weight) in enumerate(terms):
        y = 300 - 300 * k
        texture = b.texture(looked_up, uv, -600, y)
        scaled = b.vector("SCALE", texture.outputs["Color"], x=-300, y=y, scale=weight)
        color = scaled if color is None else b.vector("ADD", color, scaled, x=-150, y=y)
        multiply_add = b.node("ShaderNodeMath", -150, y - 150, operation="MULTIPLY_ADD")
        alpha = b.connect(multiply_add, ((0, texture.outputs["Alpha"]), (1, weight),
                                         (2, 0.0 if alpha is None else alpha))).outputs[0]
    if inputs.mode != "LINEAR":
        # (sum w C - mu) / sigma + mu with sigma^2 = sum_ij w_i w_j rho_ij (see BlendInputs).
        mean = (0.5, 0.5, 0.5) if inputs.mode == "HISTOGRAM" else tuple(float(c) for c in inputs.mean[:3])
        # Texton patches meet neighbours the search matched along the edge: the mappings a polygon
        # blends are strongly correlated there, so the mixture keeps its variance as it is (measured:
        # compensating as for independent mappings raised the gradient by 9-12 % next to the edges).
        if inputs.patch_zone <= 0:
            norm = b.math("MAXIMUM", b.math("SQRT", _mixture_variance(b, terms, inputs), x=0, y=500), 1e-3, 150, 500)
            inverse = b.math("DIVIDE", 1.0, norm, 300, 500)
            centred = b.vector("SUBTRACT", color, b.combine(*mean, x=0, y=300), x=150, y=300)
            color = b.vector("ADD", b.vector("SCALE", centred, x=300, y=300, scale=inverse),
                             b.combine(*mean, x=300, y=150), x=450, y=300)
    if inputs.mode == "HISTOGRAM":
        # Each channel's blended Gaussian value indexes that channel of the inverse look-up table.
        channels = []
        for c, value in enumerate(b.separate(color, 600, 300)):
            lut = b.texture(inputs.inverse_lut, b.combine(value, 0.5, 0.0, 750, 300 - 250 * c), 900, 300 - 250 * c)
            channels.append(b.separate(lut.outputs["Color"], 1150, 300 - 250 * c)[c])
        color = b.combine(*channels, x=1300, y=300)
    output = b.node("NodeGroupOutput", 1500, 0)
    b.links.new(color, output.inputs["Color"])
    b.links.new(alpha, output.inputs["Alpha"])


def ensure_blend_group(image, inputs=None):
    """Creates or rebuilds (idempotently) the blend group for (image, inputs.mode); returns it."""
    inputs = (inputs or BlendInputs()).check()
    name = group_name(image, inputs.mode, inputs.patch_zone)
    group = bpy.data.node_groups.get(name)
    if group is None:
        group = bpy.data.node_groups.new(name, "ShaderNodeTree")
    compat.ensure_group_socket(group, "Color", "OUTPUT", "NodeSocketColor")
    compat.ensure_group_socket(group, "Alpha", "OUTPUT", "NodeSocketFloat")
    group.nodes.clear()
    _build(group, image, inputs)
    return group


def _group_node(material, image, target, inputs):
    """The group node for image in material (reused when present)."""
    nodes = material.node_tree.nodes
    name = NODE_PREFIX + image.name + (" -> " + target if target != "Base Color" else "")
    group_node = nodes.get(name)
    if group_node is None:
        group_node = nodes.new("ShaderNodeGroup")
        group_node.name = name
    group_node.node_tree = ensure_blend_group(image, inputs)
    group_node.label = name
    return group_node


def _principled(material):
    nodes = material.node_tree.nodes
    found = next((n for n in nodes if n.type == "BSDF_PRINCIPLED"), None)
    if found is None:
        found = nodes.new("ShaderNodeBsdfPrincipled")
        output = next((n for n in nodes if n.type == "OUTPUT_MATERIAL"), None) or nodes.new("ShaderNodeOutputMaterial")
        material.node_tree.links.new(found.outputs["BSDF"], output.inputs["Surface"])
    return found


def insert_into_material(material, image, target="Base Color", inputs=None):
    """Drives the Principled BSDF's `target` input of material with image through TexSynth's mapping.

    target "Normal" goes through a Normal Map node (tangent space of the base TexSynth UV map) and
    blends with VARIANCE around inputs.mean (the map's mean encoded vector) whatever inputs.mode says.
    """
    if target not in TARGETS:
        raise ValueError("unknown target %r (choose one of %s)" % (target, ", ".join(TARGETS)))
    inputs = inputs or BlendInputs()
    if target == "Normal":
        inputs = dataclasses.replace(inputs, mode="VARIANCE", gaussian=None, inverse_lut=None,
                                     mean=inputs.mean if inputs.mode == "VARIANCE" else (0.5, 0.5, 1.0))
    material.use_nodes = True
    principled = _principled(material)
    group_node = _group_node(material, image, target, inputs)
    group_node.location = (principled.location[0] - 400, principled.location[1] - 200 * TARGETS.index(target))
    links = material.node_tree.links
    if target == "Normal":
        nodes = material.node_tree.nodes
        normal_map = nodes.get(group_node.name + " Normal Map") or nodes.new("ShaderNodeNormalMap")
        normal_map.name = group_node.name + " Normal Map"
        normal_map.uv_map = pipeline.BASE_UV_NAME
        normal_map.location = (group_node.location[0] + 200, group_node.location[1])
        links.new(group_node.outputs["Color"], normal_map.inputs["Color"])
        links.new(normal_map.outputs["Normal"], principled.inputs["Normal"])
    else:
        links.new(group_node.outputs["Color"], principled.inputs[target])
    return group_node


def build_material(image, inputs=None):
    """A ready material "TexSynth: <image>" (Principled BSDF fed by the blend group), reused if present."""
    material = bpy.data.materials.get(MATERIAL_PREFIX + image.name)
    if material is None:
        material = bpy.data.materials.new(MATERIAL_PREFIX + image.name)
    insert_into_material(material, image, "Base Color", inputs)
    return material


def apply_material(obj, image, mode, inputs=None):
    """mode NEW: assign the ready material to every slot; INSERT: feed each existing material's Base
    Color (NEW when the object has none); NONE: leave materials alone."""
    if mode == "NONE":
        return
    materials = [slot.material for slot in obj.material_slots if slot.material is not None]
    if mode == "INSERT" and materials:
        for material in materials:
            insert_into_material(material, image, "Base Color", inputs)
        return
    material = build_material(image, inputs)
    if not obj.material_slots:
        obj.data.materials.append(material)
    for slot in obj.material_slots:
        slot.material = material
