# SPDX-License-Identifier: GPL-3.0-or-later
"""Materials that show a colour TexSynth computed per surface sample: an image through a UV map (the
round-neighbourhood image target, a bake) or a colour attribute (the vertex target). Nodes:
UV Map -> Image Texture -> Principled Base Color, or Attribute -> Principled Base Color."""
import bpy

NODE_PREFIX = "TexSynth Surface "


def _colour_source(tree, image=None, uv_map="", attribute="", x=-350, y=0):
    """Adds (or reuses, by name) the nodes giving the colour; returns their Color output socket."""
    nodes, links = tree.nodes, tree.links

    def node(kind, name, location):
        found = nodes.get(NODE_PREFIX + name)
        if found is None or found.bl_idname != kind:
            found = nodes.new(kind)
            found.name = NODE_PREFIX + name
        found.label = NODE_PREFIX + name
        found.location = location
        return found

    if image is not None:
        texture = node("ShaderNodeTexImage", "Image", (x, y))
        texture.image = image
        texture.interpolation = "Linear"
        uv = node("ShaderNodeUVMap", "UV Map", (x - 200, y))
        uv.uv_map = uv_map
        links.new(uv.outputs["UV"], texture.inputs["Vector"])
        return texture.outputs["Color"]
    source = node("ShaderNodeAttribute", "Colour Attribute", (x, y))
    source.attribute_type = "GEOMETRY"
    source.attribute_name = attribute
    return source.outputs["Color"]


def new_material(name, image=None, uv_map="", attribute=""):
    """Material `name` (reused, its nodes rebuilt): the colour source -> Principled Base Color."""
    material = bpy.data.materials.get(name) or bpy.data.materials.new(name)
    material.use_nodes = True
    nodes, links = material.node_tree.nodes, material.node_tree.links
    nodes.clear()
    output = nodes.new("ShaderNodeOutputMaterial")
    output.location = (300, 0)
    principled = nodes.new("ShaderNodeBsdfPrincipled")
    principled.location = (0, 0)
    links.new(_colour_source(material.node_tree, image, uv_map, attribute), principled.inputs["Base Color"])
    links.new(principled.outputs["BSDF"], output.inputs["Surface"])
    return material


def insert_into_material(material, image=None, uv_map="", attribute=""):
    """Feeds the existing material's (first) Principled Base Color with the colour source."""
    from . import blend_groups
    material.use_nodes = True
    principled = blend_groups.principled_bsdf(material)
    socket = _colour_source(material.node_tree, image, uv_map, attribute,
                            principled.location[0] - 400, principled.location[1])
    material.node_tree.links.new(socket, principled.inputs["Base Color"])
    return material


def assign(obj, material):
    """Puts material in every slot of obj (adding one slot if it has none)."""
    if not obj.material_slots:
        obj.data.materials.append(material)
    for slot in obj.material_slots:
        slot.material = material


def apply(obj, mode, name, image=None, uv_map="", attribute=""):
    """mode NEW: material `name` on every slot; INSERT: each existing material's Base Color (NEW when
    the object has none); NONE: materials untouched. Returns the material made, or None."""
    if mode == "NONE":
        return None
    materials = [slot.material for slot in obj.material_slots if slot.material is not None]
    if mode == "INSERT" and materials:
        for material in materials:
            insert_into_material(material, image, uv_map, attribute)
        return None
    material = new_material(name, image, uv_map, attribute)
    assign(obj, material)
    return material
