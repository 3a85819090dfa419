# SPDX-License-Identifier: GPL-3.0-or-later
"""An artist's day in one Blender process (issue 34): random but seeded sequences of TexSynth's real
operators, with invariants checked after every step.

  blender -b --factory-startup --python-exit-code 1 --python python_tests/blender/workflow_soak.py -- \\
      --steps 300 --seed 1 [--report out/workflow_3.4.json] [--warmup 40] [--rss-bound-mb 150]
      [--max-seconds 150] [--only jumpmap,bake,...] [--verbose]

Every step is one artist action through bpy.ops: Synthesize with each method (jump map, texton, round
neighbourhoods, vector-field patches, texture particles), Analyse Sample and the other particle-view
operators, field presets, comb strokes, Field from Strokes, sources and sinks, Bake, Clear, a sample
switch, selection and settings changes, removing an object's UV map, deliberately bad settings, undo,
redo, and save + reload. After
every step (names used in the report's `violations`):

  undo / redo        ed.undo returns exactly the fingerprint recorded before the step (and before the
                     steps before it, for multi-step undo); ed.redo the one after it.
  same_inputs        the same operator re-run from the same state (undo, then run again) gives the same
                     fingerprint as the first run.
  repeat             Synthesize run again at once with the same settings gives the same fingerprint (its
                     output replaces the previous one; nothing piles up).
  failed_op_changed  an operator that returned CANCELLED (or raised its error report) changed nothing.
  failed_op_silent   an operator failed without an error report (the artist would not know why).
  uncaught_exception an operator failed with a Python traceback instead of an error report (Blender then
                     pushes an undo step anyway, and nothing undid what the operator had begun).
  unexpected_failure / unexpected_success
                     an operator the model expects to succeed failed (e.g. Bake on an object whose every
                     material shows a TexSynth result), or one given bad settings succeeded.
  reload             wm.save_mainfile + wm.open_mainfile keep the fingerprint (meshes, images and their
                     pixels, materials, node groups, child objects, settings), less the datablocks a save
                     never writes (no user, no fake user: e.g. a material a later run replaced), except
                     TexSynth's outputs (OUTPUTS: baked images and materials, surface-colour images) that
                     were made with no user (a bake with no material or a material not assigned, Layers
                     Only): those must survive, or the artist loses what the operator reported making.
  drift              the state changed between steps without an operator (fingerprint != the last one).
  exception          a step raised (the comb stroke calls the add-on's code directly; or the soak itself).
  memory             after the warm-up, RSS (VmRSS of /proc/self/status, sampled after every step) grows
                     by less than --rss-bound-mb (the undo stack holds at most `undo_steps` = 32 steps,
                     so the resident size levels off once it is full and the caches are warm).

The fingerprint: every object (type, data, parent, transform, material slots, modifiers, custom
properties, vertex groups, collections), every mesh (harness.mesh_hash: all attributes and UV maps with
their values, active indices, geometry), every material and node group (nodes, images, UV maps,
attributes, links), every image (source, size, type, colour space, packed, path and a hash of its pixels),
the collections, the names in each bpy.data collection, the scene's TexSynth settings (every property,
with the particle rows), the render engine and Cycles sampling (bake restores them), the selection and
the active object. An image saved to a file next to the .blend (not packed) counts by its path only: its
size and pixels are the file's, which a later run may rewrite and which neither undo nor the .blend holds.

Undo in background mode (found on 3.4, the same on 4.3 and 5.2): nothing special is needed beyond
--factory-startup (undo_steps 32, global undo on). The stack is empty until the first
bpy.ops.ed.undo_push (ed.undo's poll is False before it); an operator called as
bpy.ops.texsynth.x("EXEC_DEFAULT", True) pushes its step after a FINISHED run (as pressing the button
does) and pushes nothing when it is CANCELLED; Python property changes (the artist's edits in the
sidebar) are followed by bpy.ops.ed.undo_push, as the UI does for each edit. ed.undo / ed.redo run
without a context override. wm.open_mainfile empties the stack and background mode does not start a new
one: ed.undo then fails its poll ("Undo disabled at startup in background-mode (call `ed.undo_push()`
...)") until the next ed.undo_push, which this script makes right after every load. Every Python
reference to a datablock is stale after an undo, a redo or a load: this script looks everything up by
name. Modal operators (Comb, the Source/Sink pick by click)
cannot get events in background mode: the comb step runs the operator's own stroke code (its invoke's
write, CombBrush.dab per mouse position, _end_stroke's commit_edit) and pushes "Comb Field" as Blender
does when the modal operator finishes; Source/Sink runs through the operator with vertex=.

Prints per-operator counts, the violations and the RSS curve's summary; --report writes them as JSON
(with the whole RSS curve). Exit code 1 when there is a violation.
"""
import argparse
import collections
import faulthandler
import hashlib
import json
import math
import os
import random
import shutil
import sys
import tempfile
import time
import traceback

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import bpy  # noqa: E402
import numpy as np  # noqa: E402

import harness  # noqa: E402

texsynth = harness.load_addon()
texsynth.register()
from texsynth import native  # noqa: E402
from texsynth.bridge import mesh_io  # noqa: E402
from texsynth.fields import mesh_state  # noqa: E402
from texsynth.fields import authoring  # noqa: E402
from texsynth.ui import field_edits  # noqa: E402

sys.path.insert(0, harness.SAMPLES_DIR)
import particle_instances  # noqa: E402

SAMPLES = {name: os.path.join(harness.SAMPLES_DIR, name) for name in ("bricks.png", "moss.png", "bark.png")}
OBJECTS = ("Ground", "Rock")
SAMPLE_IMAGE = "Sample Moss"     # an image datablock (sample source IMAGE), a fake user keeps it
UNDO_DEPTH = 3                   # at most this many steps undone at once (the stack holds 32)
HISTORY = 12                     # fingerprints kept (>= UNDO_DEPTH + 1)


# ---------------------------------------------------------------------------------------------
# Fingerprint


def _digest(data):
    return hashlib.sha1(data).hexdigest()[:16]  # data: bytes or a contiguous array


def _round(values, digits=5):
    return tuple(round(float(v), digits) for v in values)


def _value(value):
    """A property value as something comparable and printable (IDs by name)."""
    if isinstance(value, bpy.types.ID):
        return "ID:" + value.name
    if value is None or isinstance(value, (bool, int, str)):
        return value
    if isinstance(value, float):
        return round(value, 6)
    try:
        return tuple(_value(v) for v in value)
    except TypeError:
        return repr(value)


def _rna_values(struct):
    values = {}
    for prop in struct.bl_rna.properties:
        key = prop.identifier
        if key == "rna_type":
            continue
        value = getattr(struct, key)
        if prop.type == "COLLECTION":
            values[key] = tuple(tuple(sorted(_rna_values(item).items())) for item in value)
        elif prop.type == "POINTER" and not isinstance(value, bpy.types.ID) and value is not None:
            values[key] = tuple(sorted(_rna_values(value).items()))
        else:
            values[key] = _value(value)
    return values


def image_pixels(image):
    count = len(image.pixels)  # loads file / packed buffers
    values = np.empty(count, np.float32)
    if count:
        image.pixels.foreach_get(values)
    return values


# Per node type, the attributes (besides name, type and unlinked input values) a step may change.
NODE_ATTRIBUTES = {"TEX_IMAGE": ("image", "interpolation", "extension"), "GROUP": ("node_tree",), "UVMAP": ("uv_map",),
                   "ATTRIBUTE": ("attribute_name", "attribute_type"), "OUTPUT_MATERIAL": ("is_active_output", "target"),
                   "MATH": ("operation", "use_clamp"), "VECT_MATH": ("operation",), "MIX_RGB": ("blend_type",),
                   "MIX": ("blend_type", "data_type"), "GROUP_OUTPUT": ("is_active_output",)}


def _socket_value(socket):
    value = socket.default_value
    if isinstance(value, (float, int, bool, str)):
        return value
    if isinstance(value, bpy.types.ID):
        return "ID:" + value.name
    try:
        return tuple(value)
    except TypeError:
        return repr(value)


def _tree(tree):
    if tree is None:
        return None
    nodes = []
    for node in tree.nodes:
        entry = [node.name, node.bl_idname]
        for attr in NODE_ATTRIBUTES.get(node.type, ()):
            value = getattr(node, attr, None)
            entry.append(value.name if isinstance(value, bpy.types.ID) else value)
        entry.append(tuple(_socket_value(socket) for socket in node.inputs
                           if not socket.is_linked and hasattr(socket, "default_value")))
        nodes.append(tuple(entry))
    nodes.sort(key=lambda entry: entry[0])
    links = sorted((l.from_node.name, l.from_socket.identifier, l.to_node.name, l.to_socket.identifier)
                   for l in tree.links)
    return _digest(repr((nodes, links)).encode())


DATA_KINDS = ("objects", "meshes", "materials", "node_groups", "images", "collections", "textures",
              "grease_pencils", "annotations", "grease_pencils_v3", "curves", "worlds", "cameras", "lights")


def fingerprint():
    """{key: comparable value} of everything a TexSynth step may change (see the module docstring)."""
    fp = {}
    data = bpy.data
    for kind in DATA_KINDS:
        if hasattr(data, kind):
            fp["names:" + kind] = tuple(sorted(item.name for item in getattr(data, kind)))
    for obj in data.objects:
        fp["object:" + obj.name] = (
            obj.type, obj.data.name if obj.data is not None else None, obj.parent.name if obj.parent else None,
            _round(v for row in obj.matrix_world for v in row),
            tuple(slot.material.name if slot.material else None for slot in obj.material_slots),
            tuple((m.name, m.type, m.node_group.name if getattr(m, "node_group", None) else None)
                  for m in obj.modifiers),
            tuple(sorted((k, _value(obj[k])) for k in obj.keys())),
            tuple(g.name for g in obj.vertex_groups),
            tuple(sorted(c.name for c in obj.users_collection)),
            obj.hide_render, obj.hide_viewport)
    for mesh in data.meshes:
        colours = getattr(mesh, "color_attributes", None)
        fp["mesh:" + mesh.name] = (
            harness.mesh_hash(mesh), tuple(m.name if m else None for m in mesh.materials),
            getattr(colours, "active_color_index", None), getattr(colours, "render_color_index", None))
    for material in data.materials:
        fp["material:" + material.name] = (material.use_nodes, getattr(material, "blend_method", None),
                                           _tree(material.node_tree), material.use_fake_user)
    for group in data.node_groups:
        fp["node_group:" + group.name] = (group.bl_idname, _tree(group), group.use_fake_user)
    for image in data.images:
        if image.type in ("RENDER_RESULT", "COMPOSITING"):
            continue
        # An image saved to a file (not packed) shows that file's size and pixels, which neither undo nor the
        # .blend holds (a later run may have rewritten the file).
        in_blend = image.packed_file is not None or image.source == "GENERATED" or image.is_dirty
        fp["image:" + image.name] = (
            image.source, tuple(image.size) if in_blend else "in its file", image.is_float,
            image.colorspace_settings.name, image.alpha_mode, image.packed_file is not None, image.filepath,
            image.use_fake_user, _digest(image_pixels(image)) if in_blend else "in its file")
    for coll in data.collections:
        fp["collection:" + coll.name] = (tuple(sorted(o.name for o in coll.objects)),
                                         tuple(sorted(c.name for c in coll.children)), coll.use_fake_user)
    scene = bpy.context.scene
    settings = _rna_values(scene.texsynth)
    for key, value in settings.items():
        fp["setting:" + key] = value
    cycles = getattr(scene, "cycles", None)
    fp["scene:render"] = (scene.render.engine, getattr(cycles, "samples", None),
                          getattr(cycles, "use_denoising", None), getattr(cycles, "pixel_filter_type", None),
                          scene.frame_current, tuple(sorted(o.name for o in scene.collection.objects)))
    layer = bpy.context.view_layer
    fp["scene:selection"] = (tuple(sorted(o.name for o in layer.objects if o is not None and o.select_get())),
                             layer.objects.active.name if layer.objects.active else None)
    return fp


FP_PREFIX = {"objects": "object:", "meshes": "mesh:", "materials": "material:", "node_groups": "node_group:",
             "images": "image:", "collections": "collection:"}
# TexSynth's outputs an artist asks for by name. One made with no user (a baked image with material None,
# a baked material Create but not assigned, a surface-colour image with material mode Layers Only) must
# still be there after a save + reload; one a later run replaced (nothing uses it any more) may go.
OUTPUTS = {"images": ("TexSynth Baked: ", "TexSynth Round: ", "TexSynth Patches: "),
           "materials": ("TexSynth Baked: ",)}
# Which step makes which of them. Another step can still change one: memfile undo brings back an image
# with no user that a branch (undo, then another step) had dropped, and the next step's fingerprint then
# shows it (found with seed 109): that image is an orphan, not an output.
OUTPUT_MAKERS = {"round": {"images": ("TexSynth Round: ",)},
                 "patches": {"images": ("TexSynth Patches: ",)},
                 "bake": {"images": ("TexSynth Baked: ",), "materials": ("TexSynth Baked: ",)},
                 "surface_bake": {"images": ("TexSynth Baked: ",), "materials": ("TexSynth Baked: ",)}}


def outputs_made(op, before, after):
    """{(kind, name): made with no user} for the OUTPUTS step `op` made or rewrote (fingerprint before ->
    after)."""
    made = {}
    for kind, prefixes in OUTPUT_MAKERS.get(op, {}).items():
        for item in getattr(bpy.data, kind):
            key = FP_PREFIX[kind] + item.name
            if item.name.startswith(prefixes) and before.get(key) != after.get(key):
                made[(kind, item.name)] = item.users - int(item.use_fake_user) == 0
    return made


def orphans(keep=()):
    """{(kind, name)} of the datablocks a save does not write (no user, no fake user), less `keep`."""
    found = set()
    for kind in DATA_KINDS:
        for item in getattr(bpy.data, kind, ()):
            if item.users == 0 and not item.use_fake_user and (kind, item.name) not in keep:
                found.add((kind, item.name))
    return found


def without(fp, dropped):
    """fp with the datablocks `dropped` removed (what a reload should give)."""
    fp = dict(fp)
    for kind, name in dropped:
        fp.pop(FP_PREFIX.get(kind, kind + ":") + name, None)
        key = "names:" + kind
        if key in fp:
            fp[key] = tuple(n for n in fp[key] if n != name)
    return fp


def diff(before, after, limit=8):
    """Short lines naming what differs between two fingerprints."""
    lines = []
    for key in sorted(set(before) | set(after)):
        a, b = before.get(key, "<missing>"), after.get(key, "<missing>")
        if a == b:
            continue
        if key.startswith("names:"):
            gone = sorted(set(a) - set(b)) if isinstance(a, tuple) and isinstance(b, tuple) else a
            new = sorted(set(b) - set(a)) if isinstance(a, tuple) and isinstance(b, tuple) else b
            lines.append("%s: gone %s, new %s" % (key, gone, new))
        elif key.startswith("image:") and isinstance(a, tuple) and isinstance(b, tuple):
            fields = ("source", "size", "is_float", "colorspace", "alpha_mode", "packed", "filepath", "fake_user",
                      "pixels")
            lines.append("%s: %s" % (key, ", ".join("%s %r -> %r" % (f, x, y) for f, x, y in zip(fields, a, b)
                                                      if x != y)))
        else:
            text_a, text_b = repr(a), repr(b)
            if len(text_a) > 160 or len(text_b) > 160:
                lines.append("%s: differs" % key)
            else:
                lines.append("%s: %s -> %s" % (key, text_a, text_b))
        if len(lines) >= limit:
            lines.append("...")
            break
    return lines


def signatures(violation):
    """What a violation is about, for grouping the report: per kind of datablock that differed (its name up
    to a second colon: 'image:TexSynth Segmentation'), '<invariant> after <operator>: <kind>'."""
    kinds = set()
    for line in violation["detail"]:
        head, _, rest = line.partition(": ")
        if ":" in head and rest and not head.startswith("names:"):
            kind, _, name = head.partition(":")
            kinds.add(kind + ":" + name.split(":")[0])
    if not kinds:
        kinds.add(violation["detail"][-1][:100] if violation["detail"] else "")
    return ["%s after %s: %s" % (violation["invariant"], violation["op"], kind) for kind in sorted(kinds)]


# ---------------------------------------------------------------------------------------------
# The scene


def rss_kb():
    with open("/proc/self/status") as handle:
        for line in handle:
            if line.startswith("VmRSS:"):
                return int(line.split()[1])
    return 0


def setup_scene():
    harness.reset_scene()
    bpy.context.preferences.edit.undo_steps = 32
    ground = harness.add_primitive("grid", "Ground", x_subdivisions=10, y_subdivisions=10, size=2.0)
    # No UV map on the rock: surface colour and Bake make one with Smart UV Project (the ground has Blender's).
    rock = harness.add_primitive("uv_sphere", "Rock", segments=16, ring_count=8, radius=0.6,
                                 location=(2.2, 0.3, 0.4), calc_uvs=False)
    rock.rotation_euler = (0.3, 0.0, 0.5)
    image = bpy.data.images.load(SAMPLES["moss.png"], check_existing=False)
    image.name = SAMPLE_IMAGE
    image.use_fake_user = True
    instances = particle_instances.make_collection()
    instances.use_fake_user = True
    props = bpy.context.scene.texsynth
    values = dict(sample_source="FILE", sample_path=SAMPLES["bricks.png"], sample_image=image, method="JUMPMAP",
                  scale=1.5, seed=1, jump_rate=20.0, orientation="AXIS", axis=(0.0, 0.0, 1.0),
                  direction_attribute=authoring.DIRECTION_NAME, blend=True, material_mode="NEW", working_size=512,
                  surface_target="IMAGE", bake_size=64, bake_margin=2, bake_material="NONE", bake_save_mode="PACK",
                  bake_uv_map="", bake_create_uv=True, bake_target="", round_levels=2, round_coarse_rings=2,
                  round_fine_rings=1, round_candidates=1, patch_size=16, patch_boundary=2, patch_iterations=1,
                  particle_classes=3, particle_blur=1.0, particle_collection=instances,
                  field_brush_radius=0.3, field_brush_strength=1.0, field_live_update=False)
    for key, value in values.items():
        setattr(props, key, value)
    harness.select_only([ground])
    return ground, rock


def pebbles_sample(folder):
    """A small drawn sample with clear particles for Texture Particles (96 x 64: ground, 4 stones, 2 leaves)."""
    pixels = np.ones((64, 96, 4), np.float32)
    pixels[..., :3] = (0.2, 0.3, 0.25)
    for x0, y0 in [(8, 8), (40, 8), (70, 30), (20, 40)]:
        pixels[y0:y0 + 10, x0:x0 + 10, :3] = (0.9, 0.2, 0.1)
    for x0, y0 in [(55, 6), (82, 40)]:
        pixels[y0:y0 + 14, x0:x0 + 6, :3] = (0.1, 0.6, 0.1)
    return harness.save_png(os.path.join(folder, "pebbles_small.png"), pixels)


def draw_guide_stroke(points):
    """An annotation stroke through `points` (world space): legacy strokes on 3.x and 5.x, a Grease Pencil v3
    object on 4.3 (annotation strokes cannot be made from Python there). Replaces an earlier guide."""
    if hasattr(bpy.data, "annotations"):
        data = bpy.data.annotations.get("Guide") or bpy.data.annotations.new("Guide")
        bpy.context.scene.annotation = data
    else:
        data = bpy.data.grease_pencils.get("Guide") or bpy.data.grease_pencils.new("Guide")
        bpy.context.scene.grease_pencil = data
    for layer in list(data.layers):
        data.layers.remove(layer)
    frame = data.layers.new("Note").frames.new(bpy.context.scene.frame_current)
    if hasattr(frame.strokes, "new"):
        stroke = frame.strokes.new()
        stroke.points.add(len(points))
        stroke.points.foreach_set("co", np.asarray(points, np.float32).ravel())
        return
    data.layers.remove(data.layers[0])
    gp = bpy.data.grease_pencils_v3.get("Guide") or bpy.data.grease_pencils_v3.new("Guide")
    for layer in list(gp.layers):
        gp.layers.remove(layer)
    obj = bpy.data.objects.get("Guide")
    if obj is None:
        obj = bpy.data.objects.new("Guide", gp)
        bpy.context.scene.collection.objects.link(obj)
    drawing = gp.layers.new("Guide").frames.new(bpy.context.scene.frame_current).drawing
    drawing.add_strokes([len(points)])
    local = np.asarray(points, np.float64) - np.array(obj.location)
    drawing.attributes["position"].data.foreach_set("vector", local.astype(np.float32).ravel())
    bpy.context.view_layer.update()
    obj.select_set(True)


# ---------------------------------------------------------------------------------------------
# The soak


class Soak:
    def __init__(self, args):
        self.args = args
        self.rng = random.Random(args.seed)
        self.folder = tempfile.mkdtemp(prefix="texsynth_workflow_")
        self.blend_path = os.path.join(self.folder, "workflow.blend")
        self.pebbles = pebbles_sample(self.folder)
        self.counts = collections.defaultdict(collections.Counter)
        self.seconds = collections.Counter()
        self.messages = collections.defaultdict(collections.Counter)  # per operator, its error reports
        self.violations = []
        self.rss = []
        self.history = []
        self.step = 0
        self.op = ""
        self.note = []                             # this step's settings changes, for the report
        self.trail = collections.deque(maxlen=6)   # the last steps, in each violation's report
        self.saved = False
        self.unused_outputs = {}                   # (kind, name) -> an output made with no user (see OUTPUTS)

    # -- bookkeeping ------------------------------------------------------------------------------

    def violation(self, invariant, lines):
        entry = dict(step=self.step, op=self.op, invariant=invariant, detail=list(lines)[:12],
                     settings=" ".join(self.note), recent=list(self.trail))
        self.violations.append(entry)
        self.counts[self.op]["violations"] += 1
        print("VIOLATION step %d op %s [%s]: %s" % (self.step, self.op, invariant, "; ".join(entry["detail"])),
              flush=True)

    def expect_state(self, invariant, expected, extra=()):
        """Compares the current fingerprint with `expected`; a violation (and True) when they differ."""
        now = fingerprint()
        lines = diff(expected, now)
        if lines:
            self.violation(invariant, list(extra) + lines)
            return now, True
        return now, False

    def resync(self, label="resync"):
        """After a violation the state and the undo stack no longer match the history: start a new one."""
        bpy.ops.ed.undo_push(message=label)
        self.history = [(label, fingerprint(), dict(self.unused_outputs))]

    def push(self, label):
        """An edit outside an operator (sidebar settings, selection, an annotation): one undo step, as the UI does."""
        bpy.ops.ed.undo_push(message=label)
        self.history.append((label, fingerprint(), dict(self.unused_outputs)))
        del self.history[:-HISTORY]

    @property
    def props(self):
        return bpy.context.scene.texsynth

    def call(self, operator, *args, **kwargs):
        """(status, message): FINISHED / CANCELLED, or ERROR with the error report bpy.ops raised."""
        try:
            result = operator("EXEC_DEFAULT", True, *args, **kwargs)
        except RuntimeError as error:
            return "ERROR", " ".join(str(error).split())
        return ("FINISHED" if "FINISHED" in result else "CANCELLED"), ""

    # -- one operator step, with the undo / redo / rerun checks ----------------------------------

    def run_op(self, call, expect="any", rerun=True, repeat=False):
        """call() -> (status, message). expect: 'ok', 'fail' or 'any'."""
        before = self.history[-1][1]
        started = time.perf_counter()
        status, message = call()
        self.seconds[self.op] += time.perf_counter() - started
        after = fingerprint()
        counts = self.counts[self.op]
        if status != "FINISHED":
            counts["failed"] += 1
            self.messages[self.op][(message or status)[:120]] += 1
            lines = diff(before, after)
            if "Traceback (most recent call last)" in message:
                # Not an error report but an exception the operator let through: Blender then pushes an
                # undo step all the same (3.4 to 5.2), and nothing undid what the operator had begun.
                self.violation("uncaught_exception", [message[-400:]] + lines)
                self.resync()
                return status
            if lines:
                self.violation("failed_op_changed", ["%s (%s)" % (status, message)] + lines)
                self.resync()
            if status != "ERROR":
                self.violation("failed_op_silent", ["returned %s without an error report" % status])
            if expect == "ok":
                self.violation("unexpected_failure", ["%s: %s" % (status, message)])
            return status
        counts["finished"] += 1
        if expect == "fail":
            self.violation("unexpected_success", ["the operator finished with bad settings"])
        self.unused_outputs.update(outputs_made(self.op, before, after))
        # With the outputs known then: an undo that is not redone (a branch) takes back what the step made.
        self.history.append((self.op, after, dict(self.unused_outputs)))
        del self.history[:-HISTORY]
        rng = self.rng
        if rerun and rng.random() < self.args.p_rerun:
            counts["rerun"] += 1
            bpy.ops.ed.undo()
            _, bad = self.expect_state("undo", before, ["undo before re-run"])
            if bad:
                self.resync()
                return status
            again, message = call()
            if again != "FINISHED":
                self.violation("same_inputs", ["re-run from the same state: %s %s" % (again, message)])
                self.resync()
                return status
            _, bad = self.expect_state("same_inputs", after, ["re-run from the same state"])
            if bad:
                self.resync()
                return status
        if repeat and rng.random() < self.args.p_repeat:
            counts["repeat"] += 1
            again, message = call()
            if again != "FINISHED":
                self.violation("repeat", ["run again at once: %s %s" % (again, message)])
                self.resync()
                return status
            _, bad = self.expect_state("repeat", after, ["run again at once with the same settings"])
            if bad:
                self.resync()
                return status
            self.history.append((self.op + " (again)", after, dict(self.unused_outputs)))
            del self.history[:-HISTORY]
        if rng.random() < self.args.p_undo:
            self.undo_redo()
        return status

    def undo_redo(self):
        """Undoes 1..UNDO_DEPTH steps checking each state, then usually redoes them (else the next step
        branches off, dropping them)."""
        rng = self.rng
        depth = min(len(self.history) - 1, rng.choice((1, 1, 1, 2, 3)), UNDO_DEPTH)
        if depth < 1:
            return
        counts = self.counts[self.op]
        for i in range(1, depth + 1):
            try:
                bpy.ops.ed.undo()
            except RuntimeError as error:
                self.violation("undo", ["ed.undo failed: %s" % error])
                self.resync()
                return
            counts["undo"] += 1
            label, expected, _ = self.history[-1 - i]
            _, bad = self.expect_state("undo", expected, ["%d undo(s) back to after %r" % (i, label)])
            if bad:
                self.resync()
                return
        if rng.random() < 0.8:
            for i in range(depth - 1, -1, -1):
                try:
                    bpy.ops.ed.redo()
                except RuntimeError as error:
                    self.violation("redo", ["ed.redo failed: %s" % error])
                    self.resync()
                    return
                counts["redo"] += 1
                label, expected, _ = self.history[-1 - i]
                _, bad = self.expect_state("redo", expected, ["redo to after %r" % label])
                if bad:
                    self.resync()
                    return
        else:
            del self.history[-depth:]
            self.unused_outputs = dict(self.history[-1][2])
            counts["branch"] += 1

    # -- the model: what should succeed ---------------------------------------------------------

    def selected_meshes(self):
        return [o for o in bpy.context.selected_objects if o.type == "MESH" and "texsynth_particles" not in o]

    def sample_ok(self):
        props = self.props
        if props.sample_source == "IMAGE":
            return props.sample_image is not None
        return os.path.isfile(bpy.path.abspath(props.sample_path))

    def fields_ok(self, objects):
        props = self.props
        if props.orientation != "AXIS":
            if any(props.direction_attribute not in o.data.attributes for o in objects):
                return False
        return props.scale_source == "NONE"

    @staticmethod
    def bakeable(obj):
        """The bake's preconditions, read from the object: a TexSynth UV map and every material slot showing a
        TexSynth blend group on a Principled Base Color."""
        if obj is None or obj.type != "MESH" or "TexSynth" not in obj.data.uv_layers or not obj.material_slots:
            return False
        for slot in obj.material_slots:
            material = slot.material
            if material is None or not material.use_nodes:
                return False
            if not any(l.from_node.type == "GROUP" and l.from_node.node_tree is not None
                       and l.from_node.node_tree.name.startswith("TexSynth Blend: ")
                       and l.from_socket.name == "Color" and l.to_node.type == "BSDF_PRINCIPLED"
                       and l.to_socket.name == "Base Color" for l in material.node_tree.links):
                return False
        return True

    # -- settings --------------------------------------------------------------------------------

    def set_settings(self, values, label="TexSynth settings"):
        props = self.props
        changed = False
        for key, value in values.items():
            old = getattr(props, key)
            if _value(old) != _value(value):
                setattr(props, key, value)
                changed = True
                self.note.append("%s=%s" % (key, os.path.basename(value) if key == "sample_path" else _value(value)))
        if changed:
            self.push(label)

    def common_settings(self, method):
        rng = self.rng
        objects = self.selected_meshes()
        has_field = objects and all(authoring.DIRECTION_NAME in o.data.attributes for o in objects)
        values = dict(method=method, seed=rng.choice((0, 1, 2)), scale=rng.choice((1.0, 1.5, 2.0)),
                      material_mode=rng.choice(("NEW", "NEW", "INSERT", "NONE")),
                      orientation="FIELD" if has_field and rng.random() < 0.5 else "AXIS",
                      axis=rng.choice(((0.0, 0.0, 1.0), (0.0, 1.0, 0.0), (1.0, 0.0, 0.2))),
                      direction_attribute=authoring.DIRECTION_NAME, scale_source="NONE")
        return values

    # -- operators -------------------------------------------------------------------------------

    def op_select(self):
        rng = self.rng
        choice = rng.choice((("Ground",), ("Rock",), ("Ground", "Rock"), ("Rock", "Ground")))
        objects = [bpy.data.objects[name] for name in choice]
        harness.select_only(objects)
        self.push("Select")
        self.counts[self.op]["finished"] += 1

    def op_sample_switch(self):
        rng = self.rng
        kind = rng.choice(("bricks.png", "moss.png", "bark.png", "pebbles", "IMAGE"))
        if kind == "IMAGE":
            values = dict(sample_source="IMAGE", sample_image=bpy.data.images[SAMPLE_IMAGE])
        elif kind == "pebbles":
            values = dict(sample_source="FILE", sample_path=self.pebbles)
        else:
            values = dict(sample_source="FILE", sample_path=SAMPLES[kind])
        self.set_settings(values, "Sample")
        self.counts[self.op]["finished"] += 1

    def synthesize(self, method, extra):
        values = self.common_settings(method)
        values.update(extra)
        self.set_settings(values)
        objects = self.selected_meshes()
        expect = "ok" if objects and self.sample_ok() and self.fields_ok(objects) else "any"
        if method == "PARTICLES" and (self.props.sample_source != "FILE" or self.props.sample_path != self.pebbles):
            expect = "any"  # other samples may hold no particles, or nothing but particles
        return self.run_op(lambda: self.call(bpy.ops.texsynth.synthesize), expect, repeat=True)

    def op_jumpmap(self):
        rng = self.rng
        self.synthesize("JUMPMAP", dict(jump_rate=rng.choice((10.0, 20.0)), blend=rng.random() < 0.7,
                                        blend_mode=rng.choice(("AUTO", "HISTOGRAM", "VARIANCE", "LINEAR")),
                                        neighbourhood=11))

    def op_texton(self):
        rng = self.rng
        self.synthesize("TEXTON", dict(blend=rng.random() < 0.7, blend_mode=rng.choice(("AUTO", "LINEAR")),
                                       neighbourhood=11))

    def surface_extra(self):
        rng = self.rng
        return dict(surface_target=rng.choice(("IMAGE", "IMAGE", "VERTICES")), bake_size=rng.choice((32, 64)),
                    bake_margin=2, bake_target="", round_resolution=rng.choice(("AUTO", "FULL")))

    def op_round(self):
        rng = self.rng
        extra = self.surface_extra()
        extra.update(round_levels=rng.choice((1, 2)), round_coarse_rings=rng.choice((1, 2)), round_fine_rings=1,
                     round_candidates=rng.choice((0, 1, 2)))
        self.synthesize("ROUND", extra)

    def op_patches(self):
        rng = self.rng
        extra = self.surface_extra()
        extra.update(patch_mode="OPTIMISATION" if rng.random() < 0.2 else "SAMPLING",
                     patch_size=rng.choice((16, 24)), patch_boundary=rng.choice((2, 4)), patch_iterations=1)
        self.synthesize("PATCHES", extra)

    def particle_settings(self):
        rng = self.rng
        return dict(particle_classes=rng.choice((3, 3, 4)), particle_blur=rng.choice((0.0, 1.0)),
                    particle_output=rng.choice(("DECALS", "DECALS", "INSTANCES", "BOTH")),
                    particle_background=rng.choice(("JUMPMAP", "TEXTON", "NONE")),
                    particle_size_jitter=rng.choice((0.0, 0.3)), particle_merges="", particle_class_order="",
                    particle_background_class=-1)

    def op_particles(self):
        if self.rng.random() < 0.7:  # mostly the sample particles are made for
            self.set_settings(dict(sample_source="FILE", sample_path=self.pebbles), "Sample")
        self.synthesize("PARTICLES", self.particle_settings())

    def op_particle_analyse(self):
        values = self.particle_settings()
        values["method"] = "PARTICLES"
        if self.rng.random() < 0.7:
            values.update(sample_source="FILE", sample_path=self.pebbles)
        self.set_settings(values)
        self.run_op(lambda: self.call(bpy.ops.texsynth.particle_analyse), "ok" if self.sample_ok() else "any")

    def op_particle_class(self):
        """Pick Class at a pixel, Set as Background, Merge Into or Re-synthesize Class."""
        rng, props = self.rng, self.props
        rows = len(props.particle_rows)
        kind = rng.choice(("pick", "pick", "background", "merge", "resynthesize", "resynthesize"))
        if kind == "pick":
            x, y = rng.randrange(0, 96), rng.randrange(0, 64)
            self.run_op(lambda: self.call(bpy.ops.texsynth.particle_pick_class, x=x, y=y), "any")
            return
        if rows:
            self.set_settings(dict(particle_active_class=rng.randrange(rows),
                                   particle_merge_into=rng.randrange(rows)), "Class")
        operator = {"background": bpy.ops.texsynth.particle_set_background,
                    "merge": bpy.ops.texsynth.particle_merge,
                    "resynthesize": bpy.ops.texsynth.particle_resynthesize}[kind]
        self.run_op(lambda: self.call(operator), "any")

    def active_mesh(self):
        obj = bpy.context.view_layer.objects.active
        if obj is None or obj.type != "MESH" or "texsynth_particles" in obj:
            harness.select_only([bpy.data.objects[self.rng.choice(OBJECTS)]])
            self.push("Select")
            obj = bpy.context.view_layer.objects.active
        return obj

    def field_live(self):
        live = self.rng.random() < 0.25
        self.set_settings(dict(field_live_update=live), "Live Update")

    def op_field_preset(self):
        self.active_mesh()
        self.field_live()
        preset = self.rng.choice(("AXIS", "CURVATURE", "SMOOTH"))
        iterations = self.rng.choice((1, 5, 10))
        self.run_op(lambda: self.call(bpy.ops.texsynth.field_preset, preset=preset, iterations=iterations), "ok")

    def op_singularity(self):
        obj = self.active_mesh()
        self.field_live()
        mode = self.rng.choice(("SOURCE", "SINK", "REMOVE"))
        vertex = self.rng.randrange(len(obj.data.vertices))
        self.run_op(lambda: self.call(bpy.ops.texsynth.singularity, mode=mode, vertex=vertex), "ok")

    def op_comb(self):
        """One Comb stroke: what TEXSYNTH_OT_comb runs for a drag from above (see the module docstring)."""
        obj = self.active_mesh()
        self.field_live()
        rng = self.rng
        erase = rng.random() < 0.15
        name = obj.name
        centre = np.array(obj.matrix_world.translation)
        start = centre + np.array([rng.uniform(-0.5, 0.5), rng.uniform(-0.5, 0.5), 0.0])
        heading = rng.uniform(0, 2 * math.pi)
        path = [start + t * 0.8 * np.array([math.cos(heading), math.sin(heading), 0.0]) for t in np.linspace(0, 1, 8)]

        def stroke():
            context = bpy.context
            target = bpy.data.objects[name]
            try:
                state = mesh_state.field_state(context, target)
                props = context.scene.texsynth
                brush = authoring.CombBrush(state, mesh_state.caster_for(target, state.arrays), props.field_brush_radius,
                                            props.field_brush_strength)
                mesh_state.write_field_state(target, state)  # the operator's invoke
                for point in path:
                    origin = np.array([point[0], point[1], point[2] + 5.0])
                    brush.dab(origin, np.array([0.0, 0.0, -1.0]), erase_mode=erase)
                if brush.end_stroke():
                    field_edits.commit_edit(context, target, state)
            except (ValueError, RuntimeError) as error:
                return "ERROR", str(error)
            bpy.ops.ed.undo_push(message="Comb Field")
            return "FINISHED", ""
        self.run_op(stroke, "ok", rerun=False)

    def op_strokes(self):
        """An annotation stroke along the surface, then Field from Strokes."""
        obj = self.active_mesh()
        arrays = mesh_io.read_mesh(obj)
        positions = arrays.positions
        rng = self.rng
        # A walk over nearby vertices heading one way: the polyline stays close to the surface.
        current = rng.randrange(len(positions))
        heading = positions[rng.randrange(len(positions))] - positions[current]
        points = [positions[current]]
        for _ in range(8):
            distance = np.linalg.norm(positions - positions[current], axis=1)
            near = np.argsort(distance)[1:9]
            scores = (positions[near] - positions[current]) @ heading
            current = int(near[int(np.argmax(scores))])
            points.append(positions[current])
        points = np.array(points)
        dense = np.concatenate([np.linspace(a, b, 4, endpoint=False) for a, b in zip(points[:-1], points[1:])])
        draw_guide_stroke(dense)
        harness.select_only([bpy.data.objects[obj.name]] + ([bpy.data.objects["Guide"]] if "Guide" in bpy.data.objects
                                                            else []))
        self.push("Annotate")
        self.field_live()
        self.run_op(lambda: self.call(bpy.ops.texsynth.field_from_strokes), "any")

    def op_bake(self):
        rng = self.rng
        name = self.active_mesh().name
        values = dict(bake_size=rng.choice((32, 64)), bake_margin=rng.choice((0, 2)),
                      bake_material=rng.choice(("NONE", "CREATE", "ASSIGN")), bake_target="", bake_uv_map="",
                      bake_create_uv=True,
                      bake_save_mode="NEXT_TO_BLEND" if self.saved and rng.random() < 0.3 else "PACK")
        self.set_settings(values)
        expect = "ok" if self.bakeable(bpy.data.objects[name]) else "any"
        self.run_op(lambda: self.call(bpy.ops.texsynth.bake), expect)

    def op_surface_bake(self):
        """A surface-colour run in Layers Only mode over a jump-map result, then Bake: the object still shows
        the jump-map material, so the bake must succeed."""
        name = self.active_mesh().name  # objects are looked up by name: an undo makes references stale
        harness.select_only([bpy.data.objects[name]])
        self.push("Select")
        if not self.bakeable(bpy.data.objects[name]):
            self.set_settings(dict(sample_source="FILE", sample_path=SAMPLES["moss.png"]), "Sample")
            self.synthesize("JUMPMAP", dict(material_mode="NEW", blend=True, neighbourhood=11))
        method = self.rng.choice(("ROUND", "PATCHES"))
        extra = self.surface_extra()
        extra.update(material_mode="NONE", surface_target="IMAGE")
        values = self.common_settings(method)
        values.update(extra, material_mode="NONE")
        self.set_settings(values)
        if self.run_op(lambda: self.call(bpy.ops.texsynth.synthesize), "ok") != "FINISHED":
            return
        self.set_settings(dict(bake_size=32, bake_margin=2, bake_material="NONE", bake_target="", bake_uv_map="",
                               bake_save_mode="PACK"))
        expect = "ok" if self.bakeable(bpy.data.objects[name]) else "any"
        self.run_op(lambda: self.call(bpy.ops.texsynth.bake), expect)

    def op_remove_uv(self):
        """The artist deletes an object's own UV map (mesh.uv_texture_remove): the next surface-colour run or
        Bake on it makes one with Smart UV Project again."""
        name = self.rng.choice(OBJECTS)
        mesh = bpy.data.objects[name].data
        own = [i for i, layer in enumerate(mesh.uv_layers) if not layer.name.startswith("TexSynth")]
        if not own:
            self.counts[self.op]["skipped"] += 1
            return
        harness.select_only([bpy.data.objects[name]])
        mesh.uv_layers.active_index = own[0]
        self.push("UV Map")
        self.run_op(lambda: self.call(bpy.ops.mesh.uv_texture_remove), "ok", rerun=False)

    def op_clear(self):
        if self.rng.random() < 0.3:
            harness.select_only([bpy.data.objects[name] for name in OBJECTS])
            self.push("Select")
        self.run_op(lambda: self.call(bpy.ops.texsynth.clear), "ok")

    def op_bad_settings(self):
        """Deliberately bad settings: the operator must fail with an error report and change nothing. The
        settings are put back afterwards (no undo step: the state is then the one before)."""
        rng, props = self.rng, self.props
        objects = self.selected_meshes()
        obj = self.active_mesh()
        cases = ["missing_file", "no_image", "missing_field", "missing_scale", "bad_merges", "bad_order",
                 "oversized", "bake_base_uv", "bake_missing_uv", "bad_vertex", "resynthesize_unplaced",
                 "range_round_levels", "range_patch_size", "range_classes", "range_working_size", "range_bake_size"]
        case = rng.choice(cases)
        self.counts[self.op]["case:" + case] += 1
        saved = {}

        def setting(**values):
            for key, value in values.items():
                saved.setdefault(key, getattr(props, key))
                setattr(props, key, value)

        def raw(key, value):
            """An out-of-range value as a file or a script can store it (the ID property, past RNA's clamp)."""
            saved.setdefault(key, getattr(props, key))
            props[key] = value
        synthesize = bpy.ops.texsynth.synthesize
        operator, kwargs = synthesize, {}
        if case == "missing_file":
            setting(sample_source="FILE", sample_path=os.path.join(self.folder, "no_such_sample.png"),
                    method=rng.choice(("JUMPMAP", "ROUND", "PARTICLES")))
        elif case == "no_image":
            setting(sample_source="IMAGE", sample_image=None, method=rng.choice(("JUMPMAP", "PATCHES")))
        elif case == "missing_field":
            setting(orientation="FIELD", direction_attribute="NoSuchField", method=rng.choice(("JUMPMAP", "TEXTON")))
        elif case == "missing_scale":
            setting(scale_source="ATTRIBUTE", scale_attribute="NoSuchScale", method="JUMPMAP")
        elif case == "bad_merges":
            setting(method="PARTICLES", particle_merges="two into one")
        elif case == "bad_order":
            setting(method="PARTICLES", particle_class_order="1, 1")
        elif case == "oversized":
            setting(method="JUMPMAP", scale=0.0005, allow_oversized=False)
        elif case == "bake_base_uv":
            setting(bake_uv_map="TexSynth")
            operator = bpy.ops.texsynth.bake
        elif case == "bake_missing_uv":
            setting(bake_uv_map="NoSuchUV")
            operator = bpy.ops.texsynth.bake
        elif case == "bad_vertex":
            operator, kwargs = bpy.ops.texsynth.singularity, dict(mode="SOURCE", vertex=10 ** 6)
        elif case == "range_round_levels":
            setting(method="ROUND")
            raw("round_levels", 99)
        elif case == "range_patch_size":
            setting(method="PATCHES")
            raw("patch_size", 1000)
        elif case == "range_classes":
            setting(method="PARTICLES")
            raw("particle_classes", 50)
        elif case == "range_working_size":
            setting(method=rng.choice(("JUMPMAP", "TEXTON")))
            raw("working_size", 9)
        elif case == "range_bake_size":
            raw("bake_size", 100000)
            operator = bpy.ops.texsynth.bake
        elif case == "resynthesize_unplaced":
            setting(method="PARTICLES", particle_active_class=11)
            operator = bpy.ops.texsynth.particle_resynthesize
        if operator is synthesize and not objects:
            harness.select_only([obj])
            self.push("Select")
        # The bad values are not an undo step: compare with the state before them, then put them back.
        expected = self.history[-1][1]
        status, message = self.call(operator, **kwargs)
        self.counts[self.op]["failed" if status != "FINISHED" else "finished"] += 1
        self.messages[self.op]["%s: %s" % (case, (message or status)[:110])] += 1
        for key, value in saved.items():
            setattr(props, key, value)
        if status == "FINISHED":
            self.violation("unexpected_success", ["case %s: the operator finished" % case])
            self.resync()
            return
        if "Traceback (most recent call last)" in message:
            self.violation("uncaught_exception", ["case %s: %s" % (case, message[-400:])])
            self.resync()
            return
        if status != "ERROR":
            self.violation("failed_op_silent", ["case %s: %s without an error report" % (case, status)])
        _, bad = self.expect_state("failed_op_changed", expected, ["case %s: %s" % (case, message)])
        if bad:
            self.resync()

    def op_save_reload(self):
        counts = self.counts[self.op]
        before = self.history[-1][1]
        try:
            bpy.ops.wm.save_mainfile(filepath=self.blend_path)
        except RuntimeError as error:
            self.violation("reload", ["save_mainfile failed: %s" % error])
            return
        self.saved = True
        saved = fingerprint()
        lines = diff(before, saved)
        if lines:
            self.violation("reload", ["saving changed the state"] + lines)
        dropped = orphans(keep={key for key, unused in self.unused_outputs.items() if unused})
        counts["orphans_dropped"] += len(dropped)
        bpy.ops.wm.open_mainfile(filepath=self.blend_path)
        counts["finished"] += 1
        loaded = fingerprint()
        lines = diff(without(saved, dropped), loaded)
        if lines:
            self.violation("reload", ["after save + reload"] + lines)
        # A load empties the undo stack, and background mode does not start one (ed.undo's poll: "Undo
        # disabled at startup in background-mode") until the next ed.undo_push.
        bpy.ops.ed.undo_push(message="Reload")
        self.history = [("reload", loaded, dict(self.unused_outputs))]

    OPERATORS = (("jumpmap", 10), ("texton", 6), ("round", 6), ("patches", 5), ("particles", 5),
                 ("particle_analyse", 4), ("particle_class", 3), ("field_preset", 5), ("comb", 5), ("strokes", 2),
                 ("singularity", 4), ("bake", 6), ("surface_bake", 2), ("clear", 4), ("sample_switch", 5),
                 ("select", 4), ("remove_uv", 1),
                 ("bad_settings", 6), ("save_reload", 2))

    # -- the run ---------------------------------------------------------------------------------

    def run(self):
        setup_scene()
        bpy.ops.ed.undo_push(message="Setup")
        self.history = [("setup", fingerprint(), dict(self.unused_outputs))]
        names = [name for name, _ in self.OPERATORS]
        weights = [weight for _, weight in self.OPERATORS]
        if self.args.only:
            keep = set(self.args.only.split(","))
            weights = [w if n in keep else 0 for n, w in zip(names, weights)]
        started = time.perf_counter()
        for self.step in range(self.args.steps):
            self.op = self.rng.choices(names, weights)[0]
            self.note = []
            self.counts[self.op]["steps"] += 1
            if self.step % 10 == 0:  # nothing runs between steps: checked now and then
                lines = diff(self.history[-1][1], fingerprint())
                if lines:
                    self.violation("drift", ["the state changed between steps"] + lines)
                    self.resync()
            try:
                getattr(self, "op_" + self.op)()
            except Exception:  # noqa: BLE001 - a crash of the soak's own step is a finding too
                self.violation("exception", traceback.format_exc().splitlines()[-6:])
                try:
                    self.resync()
                except Exception:  # noqa: BLE001
                    pass
            self.rss.append((self.step, rss_kb()))
            self.trail.append("%d %s %s" % (self.step, self.op, " ".join(self.note)))
            if self.args.verbose or self.step % 50 == 0:
                print("STEP %d %s rss %.1f MB (%.0f s)" % (self.step, self.op, self.rss[-1][1] / 1024.0,
                                                          time.perf_counter() - started), flush=True)
            if self.args.max_violations and len(self.violations) >= self.args.max_violations:
                print("STOP: %d violations" % len(self.violations), flush=True)
                break
            if self.args.max_seconds and time.perf_counter() - started > self.args.max_seconds:
                print("STOP: the time budget of %.0f s is spent after %d steps"
                      % (self.args.max_seconds, self.step + 1), flush=True)
                break
        self.wall = time.perf_counter() - started
        return self.finish()

    def memory_summary(self):
        values = [kb for _, kb in self.rss]
        if not values:
            return {}
        warmup = min(self.args.warmup, max(len(values) - 1, 0))
        window = values[warmup:warmup + 10] or values[-1:]
        baseline = sorted(window)[len(window) // 2]
        tail = values[-10:]
        end = sorted(tail)[len(tail) // 2]
        after = values[warmup:] or values[-1:]
        summary = dict(start_mb=values[0] / 1024.0, end_mb=values[-1] / 1024.0, max_mb=max(values) / 1024.0,
                       warmup_steps=warmup, baseline_mb=baseline / 1024.0, end_median_mb=end / 1024.0,
                       growth_mb=(max(after) - baseline) / 1024.0, bound_mb=self.args.rss_bound_mb)
        summary["within_bound"] = summary["growth_mb"] < self.args.rss_bound_mb
        return summary

    def finish(self):
        memory = self.memory_summary()
        if memory and not memory["within_bound"] and len(self.rss) > self.args.warmup + 10:
            self.op = "memory"
            self.violation("memory", ["RSS grew %.1f MB after the warm-up (%d steps), bound %.1f MB"
                                      % (memory["growth_mb"], memory["warmup_steps"], memory["bound_mb"])])
        print("== TexSynth workflow soak: Blender %s, seed %d, %d steps in %.0f s"
              % (bpy.app.version_string, self.args.seed, len(self.rss), self.wall))
        print("%-18s %6s %8s %6s %6s %6s %6s %6s %7s" % ("operator", "steps", "finished", "failed", "undo", "redo",
                                                       "rerun", "viol", "sec"))
        for name in sorted(self.counts):
            c = self.counts[name]
            print("%-18s %6d %8d %6d %6d %6d %6d %6d %7.1f" % (
                name, c["steps"], c["finished"], c["failed"], c["undo"], c["redo"], c["rerun"], c["violations"],
                self.seconds[name]))
        print("RSS MB: start %.1f, end %.1f, max %.1f; after %d warm-up steps: baseline %.1f, growth %.1f (bound %.1f)"
              % (memory.get("start_mb", 0), memory.get("end_mb", 0), memory.get("max_mb", 0),
                 memory.get("warmup_steps", 0), memory.get("baseline_mb", 0), memory.get("growth_mb", 0),
                 memory.get("bound_mb", 0)))
        findings = collections.Counter(text for v in self.violations for text in signatures(v))
        print("VIOLATIONS %d" % len(self.violations))
        for text, count in findings.most_common():
            print("  %4d violation(s): %s" % (count, text))
        for v in self.violations:
            print("  step %d op %s [%s]: %s" % (v["step"], v["op"], v["invariant"], "; ".join(v["detail"])))
        report = dict(blender=bpy.app.version_string, seed=self.args.seed, steps=len(self.rss),
                      requested_steps=self.args.steps, seconds=round(self.wall, 1),
                      native="real" if native.get() is not None else "missing",
                      counts={name: dict(c) for name, c in sorted(self.counts.items())},
                      operator_seconds={name: round(s, 2) for name, s in sorted(self.seconds.items())},
                      findings=dict(findings.most_common()), violations=self.violations, memory=memory,
                      error_reports={name: dict(c.most_common()) for name, c in sorted(self.messages.items())},
                      rss_kb=self.rss)
        if self.args.report:
            os.makedirs(os.path.dirname(os.path.abspath(self.args.report)), exist_ok=True)
            with open(self.args.report, "w") as handle:
                json.dump(report, handle, indent=1)
            print("REPORT", self.args.report)
        shutil.rmtree(self.folder, ignore_errors=True)
        return report


def parse_args(argv):
    parser = argparse.ArgumentParser(prog="workflow_soak.py", description=__doc__.split("\n\n")[0])
    parser.add_argument("--steps", type=int, default=200)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--report", default="", help="JSON report (counts, violations, RSS curve)")
    parser.add_argument("--warmup", type=int, default=40, help="steps before the memory baseline")
    parser.add_argument("--rss-bound-mb", type=float, default=150.0,
                        help="allowed RSS growth after the warm-up (MB)")
    parser.add_argument("--p-undo", type=float, default=0.35, help="chance of undo (+ usually redo) after a step")
    parser.add_argument("--p-rerun", type=float, default=0.2, help="chance of undo + the same operator again")
    parser.add_argument("--p-repeat", type=float, default=0.15, help="chance of Synthesize again at once")
    parser.add_argument("--only", default="", help="comma-separated operator names (debugging)")
    parser.add_argument("--max-violations", type=int, default=0, help="stop after this many (0: never)")
    parser.add_argument("--max-seconds", type=float, default=0.0,
                        help="stop after the step that spends this time budget (0: no budget)")
    parser.add_argument("--verbose", action="store_true")
    return parser.parse_args(argv)


def main():
    args = parse_args(harness.script_args())
    # A crash (in Blender or in TexSynth's native code) then prints the Python stack: the step and operator.
    faulthandler.enable()
    if native.get() is None:
        print("workflow_soak: texsynth_native is not available: %s" % native.reason())
        sys.exit(2)
    report = Soak(args).run()
    sys.exit(1 if report["violations"] else 0)


if __name__ == "__main__":
    main()
