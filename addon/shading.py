# SPDX-License-Identifier: GPL-3.0-or-later
"""Shader side: the node group "TexSynth Blend: <image>" = sum_k w_k * image(uv_k), and materials using it.

The group samples the image through each blend UV map (TexSynth_B0..B3), weights the samples with the
corner attribute TexSynth_Weights (RGB = w0..w2, A = 1 - w3) and adds the base map TexSynth weighted by
1 - sum(w): without blending (no weights) it shows the base mapping alone. Same nodes work in Eevee
and Cycles. One group per image: a normal or roughness map is driven through the same mapping by
inserting its own group (insert_into_material(..., target="Roughness"/"Normal")).
"""
import bpy

from . import compat, pipeline

GROUP_PREFIX = "TexSynth Blend: "
MATERIAL_PREFIX = "TexSynth: "
NODE_PREFIX = "TexSynth "
TARGETS = ("Base Color", "Roughness", "Metallic", "Normal")  # Principled inputs named alike in 3.x and 4.x


def group_name(image):
    return GROUP_PREFIX + image.name


def ensure_blend_group(image, num_blend_sets=pipeline.MAX_BLEND_SETS):
    """Creates or rebuilds (idempotently) the blend group for image; returns it."""
    group = bpy.data.node_groups.get(group_name(image))
    if group is None:
        group = bpy.data.node_groups.new(group_name(image), "ShaderNodeTree")
    compat.ensure_group_socket(group, "Color", "OUTPUT", "NodeSocketColor")
    compat.ensure_group_socket(group, "Alpha", "OUTPUT", "NodeSocketFloat")
    nodes, links = group.nodes, group.links
    nodes.clear()

    def node(kind, x, y, **props):
        new = nodes.new(kind)
        new.location = (x, y)
        for key, value in props.items():
            setattr(new, key, value)
        return new

    def sample(uv_name, x, y):
        uv = node("ShaderNodeUVMap", x, y, uv_map=uv_name)
        texture = node("ShaderNodeTexImage", x + 200, y, image=image, interpolation="Linear",
                       extension="EXTEND")
        links.new(uv.outputs["UV"], texture.inputs["Vector"])
        return texture

    def scaled(color_socket, weight_socket, x, y):
        scale = node("ShaderNodeVectorMath", x, y, operation="SCALE")
        links.new(color_socket, scale.inputs[0])
        links.new(weight_socket, scale.inputs[3])
        return scale.outputs["Vector"]

    def add(a, b, x, y):
        if a is None:
            return b
        total = node("ShaderNodeVectorMath", x, y, operation="ADD")
        links.new(a, total.inputs[0])
        links.new(b, total.inputs[1])
        return total.outputs["Vector"]

    def math(operation, a, b, x, y, c=None):
        op = node("ShaderNodeMath", x, y, operation=operation, use_clamp=operation == "SUBTRACT")
        for index, value in enumerate((a, b, c)):
            if value is None:
                continue
            if isinstance(value, float):
                op.inputs[index].default_value = value
            else:
                links.new(value, op.inputs[index])
        return op.outputs[0]

    attribute = node("ShaderNodeAttribute", -900, 300, attribute_type="GEOMETRY",
                     attribute_name=pipeline.WEIGHTS_NAME)
    separate = compat.new_separate_color_node(nodes)
    separate.location = (-700, 300)
    links.new(attribute.outputs["Color"], separate.inputs[0])
    # Alpha stores 1 - w3 (see pipeline.weights_rgba): a missing attribute reads (0,0,0,1) = no weights.
    w3 = node("ShaderNodeMath", -700, 100, operation="SUBTRACT")
    w3.inputs[0].default_value = 1.0
    links.new(attribute.outputs["Alpha"], w3.inputs[1])
    weights = compat.separate_color_outputs(separate) + [w3.outputs[0]]

    color = alpha = weight_sum = None
    for k in range(num_blend_sets):
        y = -300 * k
        texture = sample("%s%d" % (pipeline.BLEND_UV_PREFIX, k), -900, y)
        color = add(color, scaled(texture.outputs["Color"], weights[k], -400, y), -200, y)
        alpha = math("MULTIPLY_ADD", texture.outputs["Alpha"], weights[k], -250, y - 150,
                     c=alpha if alpha is not None else 0.0)
        weight_sum = weights[k] if weight_sum is None else math("ADD", weight_sum, weights[k], -500, 500 + 40 * k)
    base_weight = math("SUBTRACT", 1.0, weight_sum, -300, 600) if weight_sum is not None else None
    y = -300 * num_blend_sets
    base = sample(pipeline.BASE_UV_NAME, -900, y)
    if base_weight is None:
        color, alpha = base.outputs["Color"], base.outputs["Alpha"]
    else:
        color = add(color, scaled(base.outputs["Color"], base_weight, -400, y), -200, y)
        alpha = math("MULTIPLY_ADD", base.outputs["Alpha"], base_weight, -250, y - 150, c=alpha)
    output = node("NodeGroupOutput", 200, 0)
    links.new(color, output.inputs["Color"])
    links.new(alpha, output.inputs["Alpha"])
    return group


def _group_node(material, image, target):
    """The group node for image in material (reused when present)."""
    nodes = material.node_tree.nodes
    name = NODE_PREFIX + image.name + (" -> " + target if target != "Base Color" else "")
    group_node = nodes.get(name)
    if group_node is None:
        group_node = nodes.new("ShaderNodeGroup")
        group_node.name = name
    group_node.node_tree = ensure_blend_group(image)
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


def insert_into_material(material, image, target="Base Color"):
    """Drives the Principled BSDF's `target` input of material with image through TexSynth's mapping.

    target "Normal" goes through a Normal Map node (tangent space of the base TexSynth UV map).
    """
    if target not in TARGETS:
        raise ValueError("unknown target %r (choose one of %s)" % (target, ", ".join(TARGETS)))
    material.use_nodes = True
    principled = _principled(material)
    group_node = _group_node(material, image, target)
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


def build_material(image):
    """A ready material "TexSynth: <image>" (Principled BSDF fed by the blend group), reused if present."""
    material = bpy.data.materials.get(MATERIAL_PREFIX + image.name)
    if material is None:
        material = bpy.data.materials.new(MATERIAL_PREFIX + image.name)
    insert_into_material(material, image, "Base Color")
    return material


def apply_material(obj, image, mode):
    """mode NEW: assign the ready material to every slot; INSERT: feed each existing material's Base
    Color (NEW when the object has none); NONE: leave materials alone."""
    if mode == "NONE":
        return
    materials = [slot.material for slot in obj.material_slots if slot.material is not None]
    if mode == "INSERT" and materials:
        for material in materials:
            insert_into_material(material, image, "Base Color")
        return
    material = build_material(image)
    if not obj.material_slots:
        obj.data.materials.append(material)
    for slot in obj.material_slots:
        slot.material = material
