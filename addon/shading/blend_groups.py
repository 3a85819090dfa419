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

In VARIANCE and HISTOGRAM the jump map's weights are squared (narrower three-way zones, lower seam
ratio on curved meshes) and sqrt(sum w^2) becomes the mixture's deviation with correlated mappings
(see BlendInputs.correlation_length). The groups are written for few shader instructions (vector
nodes, no fifth look-up): Cycles' render cost was the limit (README, "Blending").

The same nodes run in Eevee and Cycles on every supported Blender. One group per (image, mode, texton zone,
Tileable); normal maps always use VARIANCE around the map's mean vector, then Blender's Normal Map node renormalises
(the histogram transform remaps X, Y, Z independently, which the Normal Map encoding does not survive).
"""
import dataclasses
import math

import bpy

from .. import compat
from ..core.layers import BASE_UV_NAME, GROUPS_NAME, SET_ATTRIBUTE_NAMES, WEIGHTS_NAME
from ..core.names import fit_name

GROUP_PREFIX = "TexSynth Blend: "
MATERIAL_PREFIX = "TexSynth: "
NODE_PREFIX = "TexSynth "
TARGETS = ("Base Color", "Roughness", "Metallic", "Normal")  # Principled inputs named alike in 3.x and 4.x
BLEND_MODES = ("HISTOGRAM", "VARIANCE", "LINEAR")  # resolved modes (core.settings.Settings also has AUTO)
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
    # Tileable: the methods' mappings run across the sample's border (a texton patch placed by the right edge
    # continues past u = 1), so the look-ups repeat the image; otherwise they extend its edge (coordinates
    # stay inside it, and a repeat would blend the opposite edge into the last half texel).
    wrap: bool = False

    def check(self):
        if self.mode not in BLEND_MODES:
            raise ValueError("unknown blend mode %r (choose one of %s)" % (self.mode, ", ".join(BLEND_MODES)))
        if self.mode == "HISTOGRAM" and (self.gaussian is None or self.inverse_lut is None):
            raise ValueError("histogram-preserving blending needs the Gaussianized image and its look-up table")
        return self


def blend_inputs(blend, image, patch_zone=0.0, wrap=False):
    """BlendInputs for uv_methods.core.BlendShading `blend` of `image` (loads the histogram images); patch_zone:
    uv_methods.core.patch_zone of the method; wrap: the run was Tileable."""
    inputs = BlendInputs(mode=blend.mode, mean=blend.mean, correlation_length=blend.correlation_length,
                         size=(int(image.size[0]), int(image.size[1])), patch_zone=patch_zone, wrap=bool(wrap))
    if blend.files is not None:
        inputs.gaussian, inputs.inverse_lut = histogram_images(blend.files, image)
    return inputs


def histogram_images(files, image):
    """(Gaussianized image, inverse look-up table) as bpy images for uv_methods.core.HistogramFiles `files`,
    packed into the .blend so it renders anywhere. The table holds the sample's own values, so it is
    read in the sample's colour space; the Gaussianized image is data."""
    loaded = []
    for path, kind, colorspace in ((files.gaussian_path, "Gaussian", "Non-Color"),
                                   (files.lut_path, "LUT", image.colorspace_settings.name)):
        name = fit_name("TexSynth %s: " % kind, image.name)
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


def group_name(image, mode="HISTOGRAM", patch_zone=0.0, wrap=False):
    return fit_name(GROUP_PREFIX, image.name, MODE_SUFFIX[mode] + (" [patches]" if patch_zone > 0 else "")
                    + (" [tiled]" if wrap else ""))


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
            if isinstance(value, (int, float)) and node.inputs[index].type == "VECTOR":
                node.inputs[index].default_value = (value, value, value)
            elif isinstance(value, (int, float, tuple)):
                node.inputs[index].default_value = value
            else:
                self.links.new(value, node.inputs[index])
        return node

    def math(self, operation, a, b=None, x=0, y=0, clamp=False, c=None):
        op = self.node("ShaderNodeMath", x, y, operation=operation, use_clamp=clamp)
        return self.connect(op, ((0, a), (1, b), (2, c))).outputs[0]

    def vector(self, operation, a, b=None, x=0, y=0, scale=None, c=None):
        op = self.node("ShaderNodeVectorMath", x, y, operation=operation)
        self.connect(op, ((0, a), (1, b), (2, c), (3, scale)))
        return op.outputs["Vector"]

    def vector_dot(self, a, b, x=0, y=0):
        op = self.node("ShaderNodeVectorMath", x, y, operation="DOT_PRODUCT")
        self.connect(op, ((0, a), (1, b)))
        return op.outputs["Value"]

    def combine(self, x_value, y_value, z_value=0.0, x=0, y=0):
        op = self.node("ShaderNodeCombineXYZ", x, y)
        return self.connect(op, ((0, x_value), (1, y_value), (2, z_value))).outputs[0]

    def separate(self, vector, x=0, y=0):
        op = self.node("ShaderNodeSeparateXYZ", x, y)
        self.links.new(vector, op.inputs[0])
        return list(op.outputs)

    def attribute(self, name, x, y):
        return self.node("ShaderNodeAttribute", x, y, attribute_type="GEOMETRY", attribute_name=name)

    def texture(self, image, vector, x, y, interpolation="Linear", extension="EXTEND"):
        texture = self.node("ShaderNodeTexImage", x, y, image=image, interpolation=interpolation, extension=extension)
        self.links.new(vector, texture.inputs["Vector"])
        return texture


@dataclasses.dataclass
class _Terms:
    """The blend group's mappings as sockets: `terms` [(uv, weight)] are what gets looked up and summed.
    For the variance: the 4 sets' uvs and weights (w012 a vector socket, w3 a float); in texton
    zones the base mapping's fade-in weight `base` and the sets' scale `rest` = 1 - base; weight_sum
    is None where the weights sum to 1."""
    terms: list
    set_uvs: list
    w012: object
    w3: object
    base: object = None
    rest: object = None
    weight_sum: object = None


def _blend_terms(b, patch_zone, sharpen=False):
    weights = b.attribute(WEIGHTS_NAME, -1600, 600)
    w012 = weights.outputs["Vector"]
    w0, w1, w2 = b.separate(w012, -1400, 600)
    # Alpha stores 1 - w3 (see uv_methods.encoding.weights_rgba): a missing attribute reads (0,0,0,1) = no weights.
    w3 = b.math("SUBTRACT", 1.0, weights.outputs["Alpha"], -1400, 450)
    set_uvs = []
    for index, name in enumerate(SET_ATTRIBUTE_NAMES):
        y = 200 - 300 * index
        sets = b.attribute(name, -1600, y)
        # Vector = (u_a, v_a, u_b): an Image Texture reads x, y only; set b is (z, alpha).
        set_uvs.append(sets.outputs["Vector"])
        z = b.separate(sets.outputs["Vector"], -1400, y)[2]
        set_uvs.append(b.combine(z, sets.outputs["Alpha"], 0.0, -1200, y))
    weights = [w0, w1, w2, w3]
    base_uv = b.node("ShaderNodeUVMap", -1600, -500, uv_map=BASE_UV_NAME).outputs["UV"]
    if patch_zone <= 0:
        total = b.math("ADD", b.vector_dot(w012, (1.0, 1.0, 1.0), -1200, 700), w3, -1000, 650)
        base_weight = b.math("SUBTRACT", 1.0, total, -800, 650, clamp=True)
        if not sharpen:
            return _Terms(list(zip(set_uvs, weights)) + [(base_uv, base_weight)], set_uvs, w012, w3)
        # Jump map, variance/histogram blending: weights w_k^2 narrow the zone where three mappings
        # mix (measured: curved-mesh seam ratio 1.043-1.120 -> 1.000-1.095 over 9 views) and stay C0,
        # since both sides of an edge see the same w_k. They are left unnormalised: the blend centres
        # each term and divides by the mixture's deviation, which scales with them (fewer shader
        # instructions, measured render cost). The base mapping weighs 1 - sum(w) = 0 wherever
        # weights exist, so instead of a fifth texture look-up it replaces set 0 where they do not
        # (a mesh without TexSynth weights then shows the base mapping, as in the other groups).
        s012 = b.vector("MULTIPLY_ADD", w012, w012, x=-1050, y=800, c=b.combine(base_weight, 0.0, 0.0, -1200, 800))
        s0, s1, s2 = b.separate(s012, -900, 800)
        s3 = b.math("MULTIPLY", w3, w3, -1050, 860)
        weight_sum = b.math("ADD", b.vector_dot(s012, (1.0, 1.0, 1.0), -900, 740), s3, -750, 740)
        towards_base = b.vector("SUBTRACT", base_uv, set_uvs[0], x=-1000, y=200)
        set_uvs[0] = b.vector("MULTIPLY_ADD", towards_base, base_weight, x=-850, y=200, c=set_uvs[0])
        return _Terms(list(zip(set_uvs, [s0, s1, s2, s3])), set_uvs, s012, s3, weight_sum=weight_sum)
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
    r0, r1, r2 = b.separate(b.vector("SCALE", w012, x=-450, y=900, scale=rest), -300, 900)
    scaled = [r0, r1, r2, b.math("MULTIPLY", w3, rest, -450, 840)]
    return _Terms(list(zip(set_uvs, scaled)) + [(base_uv, base_weight)], set_uvs, w012, w3,
                  base=base_weight, rest=rest)


def _falloffs(b, scaled, pairs, y):
    """Vector (1 + d_p^2) for 3 pairs p, d the distance between the pair's scaled coordinates:
    rho_p is its inverse. Three pairs per vector node (render cost)."""
    distances = []
    for k, (i, j) in enumerate(pairs):
        node = b.node("ShaderNodeVectorMath", -850, y - 40 * k, operation="DISTANCE")
        b.links.new(scaled[i], node.inputs[0])
        b.links.new(scaled[j], node.inputs[1])
        distances.append(node.outputs["Value"])
    d = b.combine(*distances, x=-700, y=y)
    return b.vector("MULTIPLY_ADD", d, d, x=-550, y=y, c=(1.0, 1.0, 1.0))


def _mixture_variance(b, terms, inputs):
    """Jump map: sum_ij w_i w_j rho_ij over the 4 sets (the base mapping is folded into set 0, see
    _blend_terms), with rho_ij = 1 / (1 + d_ij^2 / (2 l^2)), d_ij the texel distance between the
    mappings' coordinates (identical mappings: fully correlated; far apart: independent). A
    Cauchy-shaped falloff, not the Gaussian, and pairs three to a vector node: fewer shader
    instructions (measured render cost)."""
    width, height = inputs.size
    factor = 1.0 / (math.sqrt(2.0) * max(float(inputs.correlation_length), 1e-3))
    # Coordinates in units of sqrt(2) l (z dropped: set attributes carry another set there).
    scaled = [b.vector("MULTIPLY", uv, (width * factor, height * factor, 0.0), x=-1000, y=-900 - 60 * k)
              for k, uv in enumerate(terms.set_uvs)]
    w012, w3 = terms.w012, terms.w3
    squares = b.math("MULTIPLY_ADD", w3, w3, -250, -900, c=b.vector_dot(w012, w012, -400, -900))
    # Pairs (0,1) (1,2) (2,0) take w012 * (w1, w2, w0); pairs (0,3) (1,3) (2,3) take w012 * w3.
    w0, w1, w2 = b.separate(w012, -700, -1000)
    around = b.vector("MULTIPLY", w012, b.combine(w1, w2, w0, x=-550, y=-1000), x=-400, y=-1000)
    cross = b.vector("DIVIDE", around, _falloffs(b, scaled, ((0, 1), (1, 2), (2, 0)), -1100), x=-250, y=-1000)
    with_3 = b.vector("DIVIDE", b.vector("SCALE", w012, x=-400, y=-1300, scale=w3),
                      _falloffs(b, scaled, ((0, 3), (1, 3), (2, 3)), -1300), x=-250, y=-1300)
    cross = b.vector("ADD", cross, with_3, x=-100, y=-1100)
    return b.math("ADD", b.vector_dot(cross, (2.0, 2.0, 2.0), 50, -1000), squares, 200, -1000)


def _group_variance(b, terms):
    """Texton zones: sigma^2 = (b + r G_0)^2 + r^2 (G_1^2 + G_2^2 + G_3^2) with r = 1 - b and G the
    per-corner group weights (uv_methods.encoding.mapping_groups_rgba: identical mappings summed, distinct ones
    independent). A mesh without the attribute reads G = (0, 0, 0, 1): one independent group."""
    groups = b.attribute(GROUPS_NAME, -1600, 1200)
    g012, g3 = groups.outputs["Vector"], groups.outputs["Alpha"]
    g0 = b.separate(g012, -1400, 1200)[0]
    base, rest = terms.base, terms.rest
    own = b.math("MULTIPLY_ADD", rest, g0, -1200, 1200, c=base)
    others = b.math("MULTIPLY_ADD", g3, g3, -1100, 1100,
                    c=b.vector_dot(b.vector("MULTIPLY", g012, (0.0, 1.0, 1.0), x=-1250, y=1100), g012, -1150, 1050))
    return b.math("MULTIPLY_ADD", own, own, -500, 1100,
                  c=b.math("MULTIPLY", b.math("MULTIPLY", rest, rest, -800, 1150), others, -650, 1100))


def _build(group, image, inputs):
    b = _Builder(group)
    sharpen = inputs.mode != "LINEAR" and inputs.patch_zone <= 0
    blend = _blend_terms(b, inputs.patch_zone, sharpen)
    looked_up = inputs.gaussian if inputs.mode == "HISTOGRAM" else image
    color = alpha = 0.0
    for k, (uv, weight) in enumerate(blend.terms):
        y = 300 - 300 * k
        texture = b.texture(looked_up, uv, -600, y, extension="REPEAT" if inputs.wrap else "EXTEND")
        color = b.vector("MULTIPLY_ADD", texture.outputs["Color"], weight, x=-300, y=y, c=color)
        alpha = b.math("MULTIPLY_ADD", texture.outputs["Alpha"], weight, -300, y - 150, c=alpha)
    if inputs.mode != "LINEAR":
        # (sum w C - mu) / sigma + mu with sigma^2 = sum_ij w_i w_j rho_ij (see BlendInputs).
        mean = (0.5, 0.5, 0.5) if inputs.mode == "HISTOGRAM" else tuple(float(c) for c in inputs.mean[:3])
        # Texton zones are rescaled too, from groups of identical mappings: on stochastic samples
        # (moss, bark) distinct patches are nearly independent and the unscaled mix lost 9-12 % of
        # the gradient next to the edges. Periodic samples (bricks), whose matched patches are
        # strongly correlated, are left to Linear by Auto (uv_methods.core.blend_shading).
        variance = _mixture_variance(b, blend, inputs) if inputs.patch_zone <= 0 else _group_variance(b, blend)
        variance = b.math("MAXIMUM", variance, 1e-6, 0, 500)
        inverse = b.math("INVERSE_SQRT", variance, None, 150, 500)
        if blend.weight_sum is None:
            centred = b.vector("SUBTRACT", color, mean, x=150, y=300)
        else:  # sum_k w_k (C_k - mu)
            centred = b.vector("MULTIPLY_ADD", blend.weight_sum, tuple(-m for m in mean), x=150, y=300, c=color)
            alpha = b.math("DIVIDE", alpha, b.math("MAXIMUM", blend.weight_sum, 1e-8, 150, 150), 300, 150)
        color = b.vector("MULTIPLY_ADD", centred, inverse, x=300, y=300, c=mean)
    if inputs.mode == "HISTOGRAM":
        # Channel c of the blended Gaussian value indexes channel c of the inverse look-up table (a
        # float into the Vector socket reads the 1-row table at x = value; masks keep channel c).
        masks = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))
        result = 0.0
        for c, value in enumerate(b.separate(color, 600, 300)):
            lut = b.texture(inputs.inverse_lut, value, 900, 300 - 250 * c)
            result = b.vector("MULTIPLY_ADD", lut.outputs["Color"], masks[c], x=1150, y=300 - 250 * c, c=result)
        color = result
    output = b.node("NodeGroupOutput", 1500, 0)
    b.links.new(color, output.inputs["Color"])
    b.links.new(alpha, output.inputs["Alpha"])


def ensure_blend_group(image, inputs=None):
    """Creates or rebuilds (idempotently) the blend group for (image, inputs.mode, zone, wrap); returns it."""
    inputs = (inputs or BlendInputs()).check()
    name = group_name(image, inputs.mode, inputs.patch_zone, inputs.wrap)
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
    name = fit_name(NODE_PREFIX, image.name, " -> " + target if target != "Base Color" else "")
    group_node = nodes.get(name)
    if group_node is None:
        group_node = nodes.new("ShaderNodeGroup")
        group_node.name = name
    group_node.node_tree = ensure_blend_group(image, inputs)
    group_node.label = name
    return group_node


def principled_bsdf(material):
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
    principled = principled_bsdf(material)
    group_node = _group_node(material, image, target, inputs)
    group_node.location = (principled.location[0] - 400, principled.location[1] - 200 * TARGETS.index(target))
    links = material.node_tree.links
    if target == "Normal":
        nodes = material.node_tree.nodes
        normal_map = nodes.get(group_node.name + " Normal Map") or nodes.new("ShaderNodeNormalMap")
        normal_map.name = group_node.name + " Normal Map"
        normal_map.uv_map = BASE_UV_NAME
        normal_map.location = (group_node.location[0] + 200, group_node.location[1])
        links.new(group_node.outputs["Color"], normal_map.inputs["Color"])
        links.new(normal_map.outputs["Normal"], principled.inputs["Normal"])
    else:
        links.new(group_node.outputs["Color"], principled.inputs[target])
    return group_node


def build_material(image, inputs=None):
    """A ready material "TexSynth: <image>" (Principled BSDF fed by the blend group), reused if present."""
    name = fit_name(MATERIAL_PREFIX, image.name)
    material = bpy.data.materials.get(name)
    if material is None:
        material = bpy.data.materials.new(name)
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
