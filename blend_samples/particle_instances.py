# SPDX-License-Identifier: GPL-3.0-or-later
"""The example instance collection for Texture Particles' 3D output, made at run time (no binary asset):
collection "TexSynth Thorns" with a thorn (a curved cone, 1 unit long along +Y, base on the XY plane) and
a bead (a flattened sphere), children 0 and 1 for classes 0 and 1 (wrapping for more classes).

  blender -b --python blend_samples/particle_instances.py            # adds it to the current file
  import particle_instances; particle_instances.make_collection()   # from a script
Written for TexSynth; GPL-3.0-or-later like the rest of the repository."""
import math

import bpy

NAME = "TexSynth Thorns"


def _thorn_mesh(name, segments=12, rings=8):
    """A cone of unit length bent along +Y and rising in +Z, radius 0.18 at the base."""
    verts, faces = [], []
    for r in range(rings + 1):
        t = r / rings
        radius = 0.18 * (1.0 - t) + 0.005
        centre = (0.0, t, 0.35 * t * t)
        for s in range(segments):
            a = 2.0 * math.pi * s / segments
            verts.append((centre[0] + radius * math.cos(a), centre[1], centre[2] + radius * (0.5 + 0.5 * math.sin(a))))
    for r in range(rings):
        for s in range(segments):
            a, b = r * segments + s, r * segments + (s + 1) % segments
            faces.append((a, b, b + segments, a + segments))
    faces.append(tuple(reversed(range(segments))))
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(verts, [], faces)
    mesh.update()
    return mesh


def make_collection(scene=None):
    """The collection (made once; reused when it exists), not linked to the scene so it does not render."""
    collection = bpy.data.collections.get(NAME)
    if collection is not None:
        return collection
    collection = bpy.data.collections.new(NAME)
    thorn = bpy.data.objects.new("Thorn", _thorn_mesh("Thorn"))
    collection.objects.link(thorn)
    bead_mesh = bpy.data.meshes.new("Bead")
    import bmesh
    bm = bmesh.new()
    bmesh.ops.create_uvsphere(bm, u_segments=12, v_segments=6, radius=0.5)
    bmesh.ops.scale(bm, vec=(1.0, 1.0, 0.4), verts=bm.verts)
    bm.to_mesh(bead_mesh)
    bm.free()
    collection.objects.link(bpy.data.objects.new("Bead", bead_mesh))
    return collection


if __name__ == "__main__":
    make_collection()
