# SPDX-License-Identifier: GPL-3.0-or-later
"""The headless CLI (addon/texsynth_cli.py): exit codes, one-line errors, stats JSON, --mesh, --save."""
import json
import os

import pytest

import addon_package
import blender_run

SCENE = os.path.join(blender_run.SAMPLES, "scene.blend")
BRICKS = os.path.join(blender_run.SAMPLES, "bricks.png")

# Suzanne in blend_samples/scene.blend is Blender's monkey primitive: 507 vertices, 500 faces, 1968 corners.
SUZANNE = {"vertices": 507, "faces": 500, "corners": 1968}
needs_real = pytest.mark.skipif(not addon_package.real_synthesizer_available(),
                                reason="needs the real texsynth_native (the contract double has no oversized "
                                       "check and no fields)")


def run_failing(*args, code, fragment, blend_file=None):
    process = blender_run.cli(*args, blend_file=blend_file)
    lines = blender_run.error_lines(process)
    assert process.returncode == code, process.stdout[-2000:] + process.stderr[-2000:]
    assert len(lines) == 1 and fragment.lower() in lines[0].lower(), lines


@pytest.mark.parametrize("args, fragment", [
    ((), "required"),
    (("--sample", BRICKS), "--object"),
    (("--sample", BRICKS, "--object", "Suzanne", "--mesh", "x.obj"), "not allowed"),
    (("--sample", BRICKS, "--object", "Suzanne", "--scale", "-1"), "--scale"),
    (("--sample", BRICKS, "--object", "Suzanne", "--seed", "abc"), "--seed"),
    (("--sample", BRICKS, "--object", "Suzanne", "--render", "/no/such/dir/x.png"), "does not exist"),
])
def test_bad_arguments_exit_2_with_one_line(args, fragment):
    run_failing(*args, code=2, fragment=fragment, blend_file=SCENE)


@pytest.mark.parametrize("args, fragment", [
    (("--sample", "/no/such/sample.png", "--object", "Suzanne"), "not found"),
    (("--sample", BRICKS, "--object", "Nobody"), "no object named 'Nobody'"),
    (("--sample", BRICKS, "--object", "Camera"), "not a mesh"),
    (("--sample", BRICKS, "--mesh", "/no/such/mesh.obj"), "not found"),
    (("--sample", BRICKS, "--object", "Suzanne", "--method", "texton", "--blend-threshold", "-1"),
     "blend threshold"),
])
def test_bad_inputs_exit_1_with_one_line(args, fragment):
    run_failing(*args, code=1, fragment=fragment, blend_file=SCENE)


def test_stats_json_on_the_sample_scene(tmp_path):
    stats_path, cache = tmp_path / "stats.json", tmp_path / "cache"
    args = ("--sample", BRICKS, "--object", "Suzanne", "--scale", "0.8", "--seed", "3",
            "--cache-dir", str(cache), "--stats", str(stats_path), "--save", str(tmp_path / "out.blend"))
    process = blender_run.cli(*args, blend_file=SCENE)
    assert process.returncode == 0, process.stdout[-2000:] + process.stderr[-2000:]
    stats = json.loads(stats_path.read_text())
    assert {k: stats[k] for k in SUZANNE} == SUZANNE
    assert set(stats["seconds"]) >= {"preprocess", "synthesis", "transfer", "total"}
    assert all(v >= 0 for v in stats["seconds"].values())
    assert stats["seconds"]["total"] >= stats["seconds"]["synthesis"] + stats["seconds"]["transfer"]
    assert stats["cache_hit"] is False
    check = ("import bpy\nm = bpy.data.objects['Suzanne'].data\n"
             "names = [l.name for l in m.uv_layers]\nprint('LAYERS', names)\n"
             "assert [n for n in names if n.startswith('TexSynth')] == ['TexSynth'], names\n"
             "assert 'TexSynth_Weights' in m.attributes\n"
             "assert bpy.data.objects['Suzanne'].material_slots[0].material.name == 'TexSynth: bricks.png'\n")
    reopened = blender_run.blender("--python-expr", check, blend_file=str(tmp_path / "out.blend"))
    assert reopened.returncode == 0, reopened.stdout[-2000:] + reopened.stderr[-2000:]
    if addon_package.real_synthesizer_available():
        again = blender_run.cli(*args, blend_file=SCENE)
        assert again.returncode == 0
        assert json.loads(stats_path.read_text())["cache_hit"] is True


def test_mesh_file_import_no_blend_and_render(tmp_path):
    obj = tmp_path / "mixed.obj"
    # Three quads and a triangle: 8 vertices, 4 faces, 4 + 4 + 3 + 4 = 15 corners.
    obj.write_text("v 0 0 0\nv 1 0 0\nv 2 0 0\nv 0 1 0\nv 1 1 0\nv 2 1 0\nv 3 0.5 0\nv 1 2 0\n"
                   "f 1 2 5 4\nf 2 3 6 5\nf 3 7 6\nf 4 5 6 8\n")
    stats_path, render = tmp_path / "stats.json", tmp_path / "mesh.png"
    process = blender_run.cli("--sample", BRICKS, "--mesh", str(obj), "--scale", "4", "--no-blend",
                              "--stats", str(stats_path),
                              "--render", str(render), "--resolution", "64", "48")
    assert process.returncode == 0, process.stdout[-2000:] + process.stderr[-2000:]
    stats = json.loads(stats_path.read_text())
    assert (stats["vertices"], stats["faces"], stats["corners"]) == (8, 4, 15)
    assert render.is_file() and render.stat().st_size > 0
    assert "render" in stats["seconds"]


def ply_text(verts, faces):
    header = ["ply", "format ascii 1.0", "element vertex %d" % len(verts), "property float x", "property float y",
              "property float z", "element face %d" % len(faces), "property list uchar int vertex_indices",
              "end_header"]
    return "\n".join(header + ["%g %g %g" % v for v in verts] +
                     ["%d %s" % (len(f), " ".join(map(str, f))) for f in faces]) + "\n"


def stl_text(verts, faces):
    lines = ["solid t"]
    for f in faces:
        lines += ["facet normal 0 0 0", "outer loop"] + ["vertex %g %g %g" % verts[i] for i in f] + \
            ["endloop", "endfacet"]
    return "\n".join(lines + ["endsolid t"]) + "\n"


@pytest.mark.parametrize("kind", ["ply", "stl"])
def test_ply_and_stl_import_with_this_blenders_importer(tmp_path, kind):
    """Blender 4.0 removed import_mesh.ply/stl; compat picks wm.ply_import / wm.stl_import where they exist."""
    verts = [(x * 0.5, y * 0.5, 0.1 * ((x * y) % 3)) for y in range(4) for x in range(4)]
    faces = [(y * 4 + x, y * 4 + x + 1, y * 4 + x + 5) for y in range(3) for x in range(3)] + \
            [(y * 4 + x, y * 4 + x + 5, y * 4 + x + 4) for y in range(3) for x in range(3)]
    path = tmp_path / ("grid." + kind)
    path.write_text(ply_text(verts, faces) if kind == "ply" else stl_text(verts, faces))
    stats_path = tmp_path / "stats.json"
    process = blender_run.cli("--sample", BRICKS, "--mesh", str(path), "--scale", "2", "--stats", str(stats_path))
    assert process.returncode == 0, process.stdout[-2000:] + process.stderr[-2000:]
    stats = json.loads(stats_path.read_text())
    # STL stores every triangle's corners; the importer merges them back into 16 vertices.
    assert (stats["faces"], stats["corners"]) == (18, 54), stats
    assert stats["vertices"] == 16, stats


def test_oversized_faces_and_unknown_mesh_type_exit_1(tmp_path):
    big = tmp_path / "big.obj"
    big.write_text("v 0 0 0\nv 10 0 0\nv 10 10 0\nv 0 10 0\nf 1 2 3 4\n")  # a 10-unit quad, 1-unit sample
    run_failing("--sample", BRICKS, "--mesh", str(big), code=1, fragment="larger than")
    odd = tmp_path / "mesh.xyz"
    odd.write_text("0 0 0\n")
    run_failing("--sample", BRICKS, "--mesh", str(odd), code=1, fragment="unsupported mesh file type")


TETRA_VERTS = [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1)]
TETRA_FACES = [(0, 2, 1), (0, 1, 3), (1, 2, 3), (0, 3, 2)]


def write_tetrahedron(path):
    """The same 4-triangle tetrahedron as .obj, ASCII .ply or ASCII .stl."""
    if path.suffix == ".obj":
        lines = ["v %g %g %g" % v for v in TETRA_VERTS] + ["f %d %d %d" % tuple(i + 1 for i in f) for f in TETRA_FACES]
    elif path.suffix == ".ply":
        lines = ["ply", "format ascii 1.0", "element vertex 4", "property float x", "property float y",
                 "property float z", "element face 4", "property list uchar int vertex_indices", "end_header"]
        lines += ["%g %g %g" % v for v in TETRA_VERTS] + ["3 %d %d %d" % f for f in TETRA_FACES]
    else:
        lines = ["solid tetra"]
        for face in TETRA_FACES:
            lines += ["facet normal 0 0 0", "outer loop"] + ["vertex %g %g %g" % TETRA_VERTS[i] for i in face] + \
                     ["endloop", "endfacet"]
        lines.append("endsolid tetra")
    path.write_text("\n".join(lines) + "\n")


@pytest.mark.parametrize("suffix", [".obj", ".ply", ".stl"])
def test_mesh_importers(tmp_path, suffix):
    mesh = tmp_path / ("tetra" + suffix)
    write_tetrahedron(mesh)
    stats_path = tmp_path / "stats.json"
    process = blender_run.cli("--sample", BRICKS, "--mesh", str(mesh), "--scale", "4", "--stats", str(stats_path))
    assert process.returncode == 0, process.stdout[-2000:] + process.stderr[-2000:]
    stats = json.loads(stats_path.read_text())
    assert stats["faces"] == 4 and stats["corners"] == 12
    assert stats["vertices"] in (4, 12)  # STL stores unshared triangle corners


def test_texton_method_writes_layers_and_blended_edge_attributes(tmp_path):
    """--method texton on Suzanne: the same layers as the jump map plus the per-corner edge attributes;
    a blend threshold (scene camera) blends fewer edges than blending everything."""
    if not addon_package.real_synthesizer_available():
        pytest.skip("needs the real texsynth_native")
    counts = {}
    for name, extra in (("all", ()), ("threshold", ("--blend-threshold", "0.5"))):
        stats_path, out = tmp_path / (name + ".json"), tmp_path / (name + ".blend")
        process = blender_run.cli("--sample", BRICKS, "--object", "Suzanne", "--scale", "0.8", "--method", "texton",
                                  "--cache-dir", str(tmp_path / "cache"), "--stats", str(stats_path),
                                  "--save", str(out), *extra, blend_file=SCENE)
        assert process.returncode == 0, process.stdout[-2000:] + process.stderr[-2000:]
        native_stats = json.loads(stats_path.read_text())["native"]["Suzanne"]
        assert native_stats["faces"] == SUZANNE["faces"] and native_stats["searched_faces"] > 0
        counts[name] = native_stats["blended_edges"]
        check = ("import bpy, numpy as np\nm = bpy.data.objects['Suzanne'].data\n"
                 "names = [l.name for l in m.uv_layers]\n"
                 "assert [n for n in names if n.startswith('TexSynth')] == ['TexSynth'], names\n"
                 "a = m.attributes['TexSynth_EdgeBlended']\nassert (a.domain, a.data_type) == ('CORNER', 'FLOAT')\n"
                 "v = np.empty(len(m.loops), np.float32)\na.data.foreach_get('value', v)\n"
                 "print('BLENDED_CORNERS', int(v.sum()))\n"
                 "assert m.attributes['TexSynth_EdgeError'].domain == 'CORNER'\n")
        reopened = blender_run.blender("--python-expr", check, blend_file=str(out))
        assert reopened.returncode == 0, reopened.stdout[-2000:] + reopened.stderr[-2000:]
        corners = int(reopened.stdout.split("BLENDED_CORNERS")[1].split()[0])
        assert corners == 2 * counts[name]  # each blended (manifold) edge is listed by its two corners
    assert 0 < counts["threshold"] < counts["all"]


def cli_help():
    process = blender_run.cli("--help")
    assert process.returncode == 0, process.stdout[-2000:] + process.stderr[-2000:]
    return " ".join(process.stdout.split())


def test_blend_mode_help_says_what_auto_does():
    """Auto is not 'linear for texton patches': texton takes linear or variance by the sample's periodicity,
    the jump map histogram or variance by the histogram transform's fidelity (core/settings.py, uv_methods/core.py)."""
    settings = addon_package.load("core.settings")
    text = cli_help()
    start = text.rindex("--blend-mode {")  # the option's entry, after the usage line
    blend_help = text[start:text.index("--blend-threshold", start)]
    assert "linear for texton patches" not in blend_help.lower(), blend_help
    for number in (settings.AUTO_TEXTON_LINEAR_PERIODICITY, settings.AUTO_HISTOGRAM_MIN_FIDELITY):
        assert "%g" % number in blend_help or "%g %%" % (100 * number) in blend_help, (number, blend_help)
    for word in ("periodic", "stochastic", "variance", "histogram", "linear"):
        assert word in blend_help.lower(), (word, blend_help)


def write_quad_grid(path, cells=4, size=2.0):
    """A flat grid of cells x cells quads, `size` units wide, with one UV map (UVMap)."""
    step = size / cells
    lines = ["v %g %g 0" % (x * step, y * step) for y in range(cells + 1) for x in range(cells + 1)]
    lines += ["vt %g %g" % (x / cells, y / cells) for y in range(cells + 1) for x in range(cells + 1)]
    for y in range(cells):
        for x in range(cells):
            a = y * (cells + 1) + x + 1
            lines.append("f %d/%d %d/%d %d/%d %d/%d" % (a, a, a + 1, a + 1, a + cells + 2, a + cells + 2,
                                                        a + cells + 1, a + cells + 1))
    path.write_text("\n".join(lines) + "\n")
    return path


@pytest.mark.parametrize("extra", [("--method", "round"), ("--method", "patches"),
                                   ("--method", "round", "--target", "vertices")])
def test_surface_methods_without_an_output_are_refused(tmp_path, extra):
    """round and patches keep their colours only in the scene: with no --bake, --save, --render or --stats
    the run would write nothing, so it is refused before anything is synthesized."""
    mesh = write_quad_grid(tmp_path / "grid.obj")
    process = blender_run.cli("--sample", BRICKS, "--mesh", str(mesh), "--scale", "3", *extra)
    lines = blender_run.error_lines(process)
    assert process.returncode == 2, process.stdout[-2000:] + process.stderr[-2000:]
    assert len(lines) == 1 and "--save" in lines[0], lines
    assert ("--bake" in lines[0]) == ("vertices" not in extra), lines
    assert "TexSynth:" not in process.stdout  # no run summary: nothing was synthesized
    assert os.listdir(tmp_path) == ["grid.obj"]
    assert "--method round and patches" in cli_help()


NATIVE_OVERSIZED = ("1 of 1 faces are larger than the 512x512 sample at scale 512 texels/unit (worst face 14.1421x "
                    "the sample); lower the scale by at least that factor, subdivide those faces, or pass "
                    "allow_oversized=True")


def test_oversized_advice_in_each_interfaces_terms():
    """The native advice (lower texels per unit, allow_oversized=True) reworded: the CLI's --scale and the
    panel's Scale are world sizes, so they must be raised, and each names its own switch."""
    messages = addon_package.load("core.messages")
    cli = messages.for_interface("Plane: " + NATIVE_OVERSIZED, "CLI", 1.0)
    assert cli.startswith("Plane: 1 of 1 faces are larger than the 512x512 sample"), cli
    assert "raise --scale to at least 14.2," in cli and "--allow-oversized" in cli, cli
    assert "allow_oversized" not in cli and "lower" not in cli and "texels/unit" not in cli, cli
    panel = messages.for_interface(NATIVE_OVERSIZED, "PANEL", 2.0)
    assert "raise Scale to at least 28.3," in panel and "Allow Oversized Faces" in panel, panel
    assert "allow_oversized" not in panel and "--" not in panel, panel
    assert "allow_oversized=True" in messages.for_interface(NATIVE_OVERSIZED, "API", 1.0)
    assert messages.world_size_that_fits(1.0, 10.0) > 10.0  # a face exactly the sample's size is refused too
    assert messages.for_interface("no such advice", "CLI", 1.0) == "no such advice"


@needs_real
def test_cli_oversized_error_names_scale_to_raise_and_allow_oversized(tmp_path):
    big = tmp_path / "big.obj"
    big.write_text("v 0 0 0\nv 10 0 0\nv 10 10 0\nv 0 10 0\nf 1 2 3 4\n")  # a 10-unit quad, 1-unit sample
    process = blender_run.cli("--sample", BRICKS, "--mesh", str(big), "--scale", "1")
    lines = blender_run.error_lines(process)
    assert process.returncode == 1 and len(lines) == 1, process.stdout[-2000:] + process.stderr[-2000:]
    assert "--allow-oversized" in lines[0] and "allow_oversized" not in lines[0], lines
    assert "raise --scale to at least " in lines[0] and "lower" not in lines[0], lines
    fits = lines[0].split("raise --scale to at least ")[1].split(",")[0]
    assert float(fits) >= 10.0, lines
    stats = tmp_path / "stats.json"
    process = blender_run.cli("--sample", BRICKS, "--mesh", str(big), "--scale", fits, "--stats", str(stats))
    assert process.returncode == 0, process.stdout[-2000:] + process.stderr[-2000:]
    assert json.loads(stats.read_text())["faces"] == 1


ADDON_OVERSIZED = """
import sys
sys.path.insert(0, %r)
import bpy, harness
harness.load_addon().register()
bpy.ops.mesh.primitive_plane_add(size=10.0)
props = bpy.context.scene.texsynth
props.sample_path, props.scale, props.material_mode = %r, 1.0, "NONE"
for method in ("JUMPMAP", "TEXTON"):
    props.method = method
    try:
        bpy.ops.texsynth.synthesize()
        raise AssertionError("oversized faces were accepted")
    except RuntimeError as error:
        print("ADDON_REPORT", method, " ".join(str(error).split()))
"""


@needs_real
def test_addon_oversized_report_names_the_panels_properties():
    script = ADDON_OVERSIZED % (blender_run.BLENDER_TESTS, BRICKS)
    process = blender_run.blender("--python-expr", script)
    assert process.returncode == 0, process.stdout[-3000:] + process.stderr[-3000:]
    reports = [line for line in process.stdout.splitlines() if line.startswith("ADDON_REPORT")]
    assert len(reports) == 2, process.stdout[-3000:]
    for report in reports:
        assert "larger than" in report and "allow_oversized=True" not in report, report
        assert "raise Scale to at least " in report and "Allow Oversized Faces" in report, report


FRAMED_CHECK = """
import bpy
from bpy_extras.object_utils import world_to_camera_view
from mathutils import Vector
scene = bpy.context.scene
names = sorted(o.name for o in scene.objects)
print("OBJECTS", names)
assert "Cube" not in bpy.data.objects, names
assert scene.camera is not None and any(o.type == "LIGHT" for o in scene.objects), names
obj = bpy.data.objects["far"]
for corner in obj.bound_box:
    p = world_to_camera_view(scene, scene.camera, obj.matrix_world @ Vector(corner))
    assert 0.0 <= p.x <= 1.0 and 0.0 <= p.y <= 1.0 and p.z > 0.0, (names, tuple(p))
"""


def test_mesh_replaces_the_factory_scene_and_is_framed(tmp_path):
    """--mesh with no .blend: the factory Cube goes, and the camera and light become ones that show the mesh
    (here far from the factory camera's view); a .blend's own objects stay."""
    mesh = tmp_path / "far.obj"
    mesh.write_text("o far\n" + "".join("v %g %g 1\n" % (30 + 6 * (i % 2), -2 + 6 * (i // 2)) for i in (0, 1, 3, 2))
                    + "f 1 2 3 4\n")
    saved, render = tmp_path / "far.blend", tmp_path / "far.png"
    process = blender_run.cli("--sample", BRICKS, "--mesh", str(mesh), "--scale", "8", "--save", str(saved),
                              "--render", str(render), "--resolution", "64", "48")
    assert process.returncode == 0, process.stdout[-2000:] + process.stderr[-2000:]
    assert render.is_file()
    reopened = blender_run.blender("--python-expr", FRAMED_CHECK, blend_file=str(saved))
    assert reopened.returncode == 0, reopened.stdout[-2000:] + reopened.stderr[-2000:]
    kept = tmp_path / "kept.blend"
    process = blender_run.cli("--sample", BRICKS, "--mesh", str(mesh), "--scale", "8", "--save", str(kept),
                              blend_file=SCENE)
    assert process.returncode == 0, process.stdout[-2000:] + process.stderr[-2000:]
    check = ("import bpy\nnames = set(bpy.data.objects.keys())\nprint('OBJECTS', names)\n"
             "assert {'Suzanne', 'far', bpy.context.scene.camera.name} <= names\n"
             "assert not any(n.startswith('TexSynth') for n in names), names\n")
    reopened = blender_run.blender("--python-expr", check, blend_file=str(kept))
    assert reopened.returncode == 0, reopened.stdout[-2000:] + reopened.stderr[-2000:]


def write_tube(path, segments=24, rows=8):
    """An open tube along z, radius 0.5, length 3 (the least-curvature direction is along it)."""
    import math
    verts = ["v %.6f %.6f %.6f" % (0.5 * math.cos(2 * math.pi * j / segments), 0.5 * math.sin(2 * math.pi * j / segments),
                                   -1.5 + 3.0 * i / rows) for i in range(rows + 1) for j in range(segments)]
    faces = ["f %d %d %d %d" % (i * segments + j + 1, i * segments + (j + 1) % segments + 1,
                                (i + 1) * segments + (j + 1) % segments + 1, (i + 1) * segments + j + 1)
             for i in range(rows) for j in range(segments)]
    path.write_text("o tube\n" + "\n".join(verts + faces) + "\n")
    return path


# Loads the CLI's saved results, then makes them again with the add-on's own operators on the same mesh.
FIELD_CHECK = """
import sys
sys.path.insert(0, %(tests)r)
import bpy, numpy as np, harness
def vectors(name):
    mesh = bpy.data.objects["tube"].data
    values = np.zeros(len(mesh.vertices) * 3, np.float32)
    mesh.attributes[name].data.foreach_get("vector", values)
    return values.reshape(-1, 3)
def uvs():
    mesh = bpy.data.objects["tube"].data
    values = np.zeros(len(mesh.loops) * 2, np.float32)
    mesh.uv_layers["TexSynth"].data.foreach_get("uv", values)
    return values.reshape(-1, 2)
cli = {}
for name in ("curvature", "axis_x", "synth_x"):
    bpy.ops.wm.open_mainfile(filepath=%(folder)r + "/" + name + ".blend")
    cli[name] = uvs() if name == "synth_x" else vectors("TexSynth_Direction")
harness.reset_scene()
harness.load_addon().register()
bpy.ops.wm.obj_import(filepath=%(mesh)r) if hasattr(bpy.ops.wm, "obj_import") else bpy.ops.import_scene.obj(filepath=%(mesh)r)
harness.select_only([bpy.data.objects["tube"]])
props = bpy.context.scene.texsynth
props.sample_path, props.scale, props.blend, props.material_mode = %(sample)r, 1.0, False, "NONE"
assert bpy.ops.texsynth.field_preset(preset="CURVATURE") == {"FINISHED"}
curvature = vectors("TexSynth_Direction")
props.axis = (1.0, 0.0, 0.0)
assert bpy.ops.texsynth.field_preset(preset="AXIS") == {"FINISHED"}
axis_x = vectors("TexSynth_Direction")
print("DIFFERENCES", np.abs(cli["curvature"] - curvature).max(), np.abs(cli["axis_x"] - axis_x).max())
assert np.allclose(cli["curvature"], curvature, atol=1e-5) and np.allclose(cli["axis_x"], axis_x, atol=1e-5)
assert np.median(np.abs(curvature[:, 2])) > 0.99 and np.median(np.abs(axis_x[:, 2])) < 0.1
props.orientation, props.axis = "AXIS", (-1.0, 0.0, 0.0)
assert bpy.ops.texsynth.synthesize() == {"FINISHED"}
synth_x = uvs()
props.axis = (0.0, 0.0, 1.0)
assert bpy.ops.texsynth.synthesize() == {"FINISHED"}
print("UV", np.abs(cli["synth_x"] - synth_x).max(), np.abs(cli["synth_x"] - uvs()).max())
assert np.allclose(cli["synth_x"], synth_x, atol=1e-5) and not np.allclose(cli["synth_x"], uvs(), atol=1e-3)
print("FIELDS_MATCH")
"""


@needs_real
def test_axis_and_field_preset_match_the_addon(tmp_path):
    """--field-preset runs the add-on's Field Preset (the direction it writes is the operator's, and the
    synthesis follows it); --axis is the panel's Axis (X = (1, 0, 0); `--axis -X` too, which argparse alone
    would take for an option)."""
    mesh = write_tube(tmp_path / "tube.obj")
    common = ("--sample", BRICKS, "--mesh", str(mesh), "--scale", "1", "--no-blend", "--material", "none")
    for name, extra in (("curvature", ("--field-preset", "curvature")),
                        ("axis_x", ("--field-preset", "axis", "--axis", "X")), ("synth_x", ("--axis", "-X"))):
        stats = tmp_path / (name + ".json")
        process = blender_run.cli(*common, *extra, "--save", str(tmp_path / (name + ".blend")), "--stats", str(stats))
        assert process.returncode == 0, process.stdout[-2000:] + process.stderr[-2000:]
    script = FIELD_CHECK % dict(tests=blender_run.BLENDER_TESTS, folder=str(tmp_path), mesh=str(mesh), sample=BRICKS)
    check = blender_run.blender("--python-expr", script)
    assert check.returncode == 0 and "FIELDS_MATCH" in check.stdout, check.stdout[-3000:] + check.stderr[-3000:]


@pytest.mark.parametrize("args, fragment", [
    (("--axis", "W"), "--axis"),
    (("--axis", "0,0,0"), "--axis"),
    (("--field-preset", "curvature", "--direction-attribute", "Other"), "--direction-attribute"),
    (("--field-preset", "spiral"), "--field-preset"),
])
def test_bad_axis_and_field_preset_exit_2(args, fragment):
    run_failing("--sample", BRICKS, "--object", "Suzanne", *args, code=2, fragment=fragment, blend_file=SCENE)
