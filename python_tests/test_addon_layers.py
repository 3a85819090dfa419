# SPDX-License-Identifier: GPL-3.0-or-later
"""The add-on's layering (docs/dev/architecture.md), read from its imports with `ast`, imports inside
functions included: data flows Blender -> bridge -> core/method -> native -> bridge -> Blender, so a
package may import only from its own layer's shared packages below it, never upwards, and no module
takes part in an import circle."""
import ast
import os

ADDON = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "addon")

# Lower numbers are lower layers. A package may import packages of a strictly lower layer, and itself.
LAYERS = {
    "compat": 0, "native": 0,                         # Blender version checks; the lazily loaded native module
    "core": 1,                                        # bpy-free core: settings, reports, sample, layers
    "bridge": 2,                                      # all bpy mesh and image I/O
    "shading": 3, "fields": 3,                        # shared node groups; direction-field authoring
    "uv_methods": 4, "surface_colour": 4,             # method families
    "particles": 5,                                   # uses a UV method for its background
    "bake": 6,                                        # bakes any family's result
    "methods": 6,                                     # the method registry: every family's MethodFamily
    "ui": 7, "cli": 7,                                # the two interfaces: the panel, the command line in Blender
    "__init__": 8, "texsynth_cli": 8,                 # their entry points (register; the CLI script)
    "texsynth_batch": 9,                              # batch runs of the CLI on Dask (outside Blender)
}
BPY_FREE = ("core",)  # never import bpy (or Blender-only modules) at all
BLENDER_ONLY = {"bpy", "bmesh", "mathutils", "gpu", "gpu_extras", "bpy_extras", "bl_math"}
MAX_LINES = 450


def modules():
    """{dotted module name: path} for every add-on file."""
    found = {}
    for folder, _, files in os.walk(ADDON):
        for name in files:
            if name.endswith(".py"):
                path = os.path.join(folder, name)
                rel = os.path.relpath(path, ADDON)[:-3].replace(os.sep, ".")
                found[rel[:-len(".__init__")] if rel.endswith(".__init__") else rel] = path
    return found


def imports_of(module, path, known):
    """[(imported add-on module, line)] and [(external top-level module, line)] of one file."""
    package = module.split(".") if path.endswith("__init__.py") else module.split(".")[:-1]
    inner, outer = [], []
    for node in ast.walk(ast.parse(open(path).read())):
        if isinstance(node, ast.ImportFrom) and node.level:
            base = package[:len(package) - node.level + 1]
            stem = base + (node.module.split(".") if node.module else [])
            for alias in node.names:
                candidate = ".".join(stem + [alias.name])
                inner.append((candidate if candidate in known else ".".join(stem), node.lineno))
        elif isinstance(node, ast.ImportFrom):
            top = node.module.split(".")[0]
            if top == "texsynth":  # the CLI imports the registered add-on by its package name
                stem = node.module.split(".")[1:]
                for alias in node.names:
                    candidate = ".".join(stem + [alias.name])
                    inner.append((candidate if candidate in known else ".".join(stem), node.lineno))
            else:
                outer.append((top, node.lineno))
        elif isinstance(node, ast.Import):
            outer += [(alias.name.split(".")[0], node.lineno) for alias in node.names]
    return [(name, line) for name, line in inner if name], outer


def layer_of(module):
    return LAYERS[module.split(".")[0]]


def test_every_package_has_a_layer():
    assert sorted({m.split(".")[0] for m in modules()} - set(LAYERS)) == []


def test_no_import_reaches_a_higher_layer_or_a_sibling_package():
    known = modules()
    wrong = []
    for module, path in sorted(known.items()):
        inner, _ = imports_of(module, path, known)
        for target, line in inner:
            same_package = target.split(".")[0] == module.split(".")[0]
            if not same_package and layer_of(target) >= layer_of(module):
                wrong.append("%s:%d imports %s (layer %d -> %d)"
                             % (os.path.relpath(path, ADDON), line, target, layer_of(module), layer_of(target)))
    assert wrong == [], "\n".join(wrong)


def test_the_core_never_imports_blender():
    known = modules()
    wrong = ["%s:%d imports %s" % (os.path.relpath(path, ADDON), line, name)
             for module, path in sorted(known.items()) if module.split(".")[0] in BPY_FREE
             for name, line in imports_of(module, path, known)[1] if name in BLENDER_ONLY]
    assert wrong == [], "\n".join(wrong)


def test_no_import_circle():
    known = modules()
    graph = {m: {t for t, _ in imports_of(m, p, known)[0] if t in known and t != m} for m, p in known.items()}
    # A package's __init__ is imported with any of its modules: an edge to a module implies one to its packages.
    circles, state = [], {}

    def visit(node, stack):
        state[node] = "open"
        stack.append(node)
        for nxt in sorted(graph[node]):
            if state.get(nxt) == "open":
                circles.append(" -> ".join(stack[stack.index(nxt):] + [nxt]))
            elif nxt not in state:
                visit(nxt, stack)
        stack.pop()
        state[node] = "done"

    for node in sorted(graph):
        if node not in state:
            visit(node, [])
    assert circles == [], "\n".join(circles)


def test_no_file_over_the_line_limit():
    long = ["%s: %d lines" % (os.path.relpath(path, ADDON), n) for path in sorted(modules().values())
            for n in [sum(1 for _ in open(path))] if n > MAX_LINES]
    assert long == [], "\n".join(long)


def test_the_checker_sees_a_planted_upward_import(tmp_path, monkeypatch):
    # The checks above must be able to fail: a bridge module importing the UI is reported.
    planted = tmp_path / "addon"
    (planted / "bridge").mkdir(parents=True)
    (planted / "ui").mkdir()
    (planted / "bridge" / "__init__.py").write_text("")
    (planted / "ui" / "__init__.py").write_text("")
    (planted / "ui" / "panels.py").write_text("X = 1\n")
    (planted / "bridge" / "mesh_io.py").write_text("def f():\n    from ..ui import panels\n    return panels.X\n")
    monkeypatch.setattr(__import__(__name__), "ADDON", str(planted))
    try:
        test_no_import_reaches_a_higher_layer_or_a_sibling_package()
    except AssertionError as error:
        assert "bridge/mesh_io.py:2 imports ui.panels (layer 2 -> 7)" in str(error)
    else:
        raise AssertionError("the planted upward import was not reported")
