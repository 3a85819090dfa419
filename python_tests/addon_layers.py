# SPDX-License-Identifier: GPL-3.0-or-later
"""The add-on's layering rules (docs/dev/architecture.md) as functions over any add-on folder, read from its
imports with `ast`, imports inside functions included: python_tests/core/test_addon_layers.py applies them to
addon/, python_tests/blender/test_method_registry.py to a copy with a toy method family added."""
import ast
import os

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


def modules(addon):
    """{dotted module name: path} for every file of the add-on folder."""
    found = {}
    for folder, _, files in os.walk(addon):
        for name in files:
            if name.endswith(".py"):
                path = os.path.join(folder, name)
                rel = os.path.relpath(path, addon)[:-3].replace(os.sep, ".")
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


def packages_without_layer(addon, layers=LAYERS):
    return sorted({m.split(".")[0] for m in modules(addon)} - set(layers))


def upward_or_sideways_imports(addon, layers=LAYERS):
    """["file:line imports module (layer a -> b)"] for every import of a package at its own layer or above."""
    known = modules(addon)
    wrong = []
    for module, path in sorted(known.items()):
        inner, _ = imports_of(module, path, known)
        for target, line in inner:
            same_package = target.split(".")[0] == module.split(".")[0]
            mine, theirs = layers[module.split(".")[0]], layers[target.split(".")[0]]
            if not same_package and theirs >= mine:
                wrong.append("%s:%d imports %s (layer %d -> %d)" % (os.path.relpath(path, addon), line, target, mine,
                                                                    theirs))
    return wrong


def blender_imports_in_the_core(addon):
    known = modules(addon)
    return ["%s:%d imports %s" % (os.path.relpath(path, addon), line, name)
            for module, path in sorted(known.items()) if module.split(".")[0] in BPY_FREE
            for name, line in imports_of(module, path, known)[1] if name in BLENDER_ONLY]


def import_circles(addon):
    """["a -> b -> a"] for every circle of imports between add-on modules."""
    known = modules(addon)
    graph = {m: {t for t, _ in imports_of(m, p, known)[0] if t in known and t != m} for m, p in known.items()}
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
    return circles


def long_files(addon):
    return ["%s: %d lines" % (os.path.relpath(path, addon), n) for path in sorted(modules(addon).values())
            for n in [sum(1 for _ in open(path))] if n > MAX_LINES]
