# SPDX-License-Identifier: GPL-3.0-or-later
"""The method registry (addon/methods.py, docs/dev/architecture.md "Registry"): every registered method
declares each part the interfaces ask for, nothing outside the families compares method names, and adding a
method is one package and one registry line: a toy method added that way to a copy of the add-on is offered
by the CLI parser with its options, validated through its own check, drawn by the Method panel from its own
section, given panel properties, and run by the Synthesize operator, with no other file edited."""
import ast
import json
import os
import re
import shutil
import subprocess

import pytest

import addon_package

methods = addon_package.load("methods")
core_settings = addon_package.load("core.settings")
method_spec = addon_package.load("core.method_spec")

SPEC_PARTS = ("validate", "draw", "panel_settings", "make_job", "synthesize")
FAMILY_PARTS = ("add_cli_options", "check_cli_args", "check_cli_outputs", "settings_from_cli", "prepare_cli_run",
                "panel_properties")
# Where method names may not be compared: everything that should ask the registry (the families themselves
# may branch on their own members).
ASKS_THE_REGISTRY = ("ui", "cli", "texsynth_cli.py", "core", "methods.py", "bake", "__init__.py")


def test_every_registered_method_declares_each_part():
    specs = methods.all_methods()
    assert [spec.id for spec in specs] == ["JUMPMAP", "TEXTON", "ROUND", "PATCHES", "PARTICLES"]
    assert list(core_settings.METHODS) == [spec.id for spec in specs]
    for spec in specs:
        assert isinstance(spec, method_spec.MethodSpec)
        assert spec.id.isupper() and spec.cli_name == spec.id.lower() and spec.label and spec.description, spec
        for part in SPEC_PARTS:
            assert callable(getattr(spec, part)), (spec.id, part)
        assert methods.get(spec.id) is spec and methods.by_cli_name(spec.cli_name) is spec
        assert spec in methods.family_of(spec).methods
        # the shared checks pass for the defaults, and each method's own check accepts them
        assert core_settings.Settings(method=spec.id, particle_collection="C").validate().method == spec.id
    owned = {}
    defaults = core_settings.Settings()
    for family in methods.FAMILIES:
        for part in FAMILY_PARTS:
            assert callable(getattr(family, part)), (family.name, part)
        assert os.path.isfile(os.path.join(addon_package.ADDON_DIR, family.name, "method.py")), family.name
        for name in family.settings_fields:
            assert hasattr(defaults, name), (family.name, name)  # its default is written once, in Settings
            assert owned.setdefault(name, family.name) == family.name, "%s owned twice" % name
    assert methods.enum_items() == tuple((spec.id, spec.label, spec.description) for spec in specs)


def test_an_unknown_method_is_refused_with_the_registered_ones():
    with pytest.raises(core_settings.SettingsError, match="choose one of JUMPMAP, TEXTON, ROUND, PATCHES, PARTICLES"):
        core_settings.Settings(method="NOPE").validate()
    with pytest.raises(KeyError):
        methods.get("NOPE")


def method_name_comparisons(root):
    """['file:line compares with "NAME"'] for comparisons with a method's id or CLI name outside the families."""
    names = {spec.id for spec in methods.all_methods()} | {spec.cli_name for spec in methods.all_methods()}
    found = []
    for folder, _, files in os.walk(root):
        for file_name in files:
            path = os.path.join(folder, file_name)
            rel = os.path.relpath(path, root)
            if not file_name.endswith(".py") or not rel.startswith(ASKS_THE_REGISTRY):
                continue
            for node in ast.walk(ast.parse(open(path).read())):
                if isinstance(node, ast.Compare):
                    for value in [node.left] + node.comparators:
                        elements = value.elts if isinstance(value, (ast.Tuple, ast.List, ast.Set)) else [value]
                        found += ["%s:%d compares with %r" % (rel, node.lineno, e.value) for e in elements
                                  if isinstance(e, ast.Constant) and e.value in names]
    return found


def test_the_interfaces_never_compare_method_names(tmp_path):
    assert method_name_comparisons(addon_package.ADDON_DIR) == []
    # the check can fail: a panel branching on a method's name is reported
    (tmp_path / "ui").mkdir()
    (tmp_path / "ui" / "panels.py").write_text("def draw(props):\n    return props.method in ('ROUND', 'X')\n")
    assert method_name_comparisons(str(tmp_path)) == ["ui/panels.py:2 compares with 'ROUND'"]


TOY_METHOD = '''# SPDX-License-Identifier: GPL-3.0-or-later
"""A test's method: a family package with one method and one setting of its own."""
from ..core.method_spec import MethodFamily, MethodSpec
from ..core.reporting import Report
from ..core.settings import SettingsError

STRENGTH = 2.0
RUNS = []


def validate(settings):
    strength = settings.method_options.get("toy_strength", STRENGTH)
    if not 0.0 < strength <= 10.0:
        raise SettingsError("toy strength must be in (0, 10], got %r" % strength)


def draw(layout, props, context):
    layout.prop(props, "toy_strength")


def panel_settings(props):
    return {"method_options": {"toy_strength": float(props.toy_strength)}}


class Job:
    def __init__(self, run):
        self.run, self.sample, self.report = run, run.sample, Report()

    def prepare(self):
        self.run.settings.validate()
        return self

    def compute(self, progress=None):
        return self

    def apply(self, progress=None):
        self.report.objects = [obj.name for obj in self.run.objects]
        RUNS.append((self.run.settings.method, self.run.settings.method_options, self.report.objects))
        return self.report

    def discard(self):
        pass


def make_job(run):
    return Job(run)


def synthesize(run):
    return Job(run).prepare().compute().apply()


def add_cli_options(parser, defaults):
    parser.add_argument("--toy-strength", type=float, default=None, help="toy: its strength")


def check_cli_args(args, spec, defaults):
    if args.toy_strength is not None and spec is not TOY:
        return "--toy-strength is for --method toy"
    return None


def settings_from_cli(args, spec, defaults):
    if spec is not TOY:
        return {}
    return {"method_options": {"toy_strength": STRENGTH if args.toy_strength is None else args.toy_strength}}


def panel_properties(props):
    return {"toy_strength": props.FloatProperty(name="Strength", default=STRENGTH)}


TOY = MethodSpec("TOY", "toy", "Toy", "A test's method", validate=validate, draw=draw, panel_settings=panel_settings,
                 make_job=make_job, synthesize=synthesize)
FAMILY = MethodFamily("toy", (TOY,), option_defaults={"toy_strength": STRENGTH}, add_cli_options=add_cli_options,
                      check_cli_args=check_cli_args, settings_from_cli=settings_from_cli,
                      panel_properties=panel_properties)
'''

REGISTRY_LINE = "from .toy.method import FAMILY as toy\n"

IN_BLENDER = '''
import json, sys, types
import bpy
addon_dir = sys.argv[sys.argv.index("--") + 1]
sys.path.insert(0, addon_dir)
import texsynth_cli
addon = texsynth_cli.load_addon()
assert not addon.UNSUPPORTED, addon.UNSUPPORTED
addon.register()
from texsynth import methods
from texsynth.core.settings import Settings, SettingsError
from texsynth.toy import method as toy
from texsynth.ui import panels
out = {}
base = ["--sample", "s.png", "--object", "Cube"]
args = texsynth_cli.parse_args(base + ["--method", "toy", "--toy-strength", "3"])
settings = texsynth_cli.settings_from_args(args, Settings, methods)
out["cli"] = [settings.method, settings.method_options]
for extra in (["--method", "jumpmap", "--toy-strength", "3"], ["--method", "nope"]):
    try:
        texsynth_cli.parse_args(base + extra)
    except texsynth_cli.UsageError as error:
        out.setdefault("usage", []).append(str(error))
try:
    Settings(method="TOY", method_options={"toy_strength": 50.0}).validate()
except SettingsError as error:
    out["validate"] = str(error)
props = bpy.context.scene.texsynth
props.method = "TOY"
out["default"] = props.toy_strength
class Layout:
    def __init__(self, calls):
        self.calls = calls
    def __getattr__(self, name):
        def record(*args, **kwargs):
            self.calls.append([name] + [a for a in args if isinstance(a, str)] + sorted(kwargs.get(k) for k in kwargs if k == "text"))
            return self
        return record
calls = []
panels.TEXSYNTH_PT_method.draw(types.SimpleNamespace(layout=Layout(calls)), bpy.context)
out["drawn"] = calls
props.toy_strength = 4.0
bpy.ops.object.select_all(action="DESELECT")
bpy.data.objects["Cube"].select_set(True)
out["operator"] = sorted(bpy.ops.texsynth.synthesize())
out["runs"] = [[m, o, names] for m, o, names in toy.RUNS]
print("RESULT " + json.dumps(out), flush=True)
'''


def copy_with_toy(tmp_path):
    """The add-on's Python files with the toy package and its one registry line: the only change."""
    addon = tmp_path / "addon"
    shutil.copytree(addon_package.ADDON_DIR, addon, ignore=shutil.ignore_patterns("*.so", "__pycache__"))
    (addon / "toy").mkdir()
    (addon / "toy" / "__init__.py").write_text('# SPDX-License-Identifier: GPL-3.0-or-later\n"""Toy."""\n')
    (addon / "toy" / "method.py").write_text(TOY_METHOD)
    registry = (addon / "methods.py").read_text()
    last_family = "from .particles.method import FAMILY as particles\n"
    assert last_family in registry
    (addon / "methods.py").write_text(registry.replace(last_family, last_family + REGISTRY_LINE))
    return addon


def test_a_toy_method_is_one_package_and_one_registry_line(tmp_path):
    addon = copy_with_toy(tmp_path)
    script = tmp_path / "toy_in_blender.py"
    script.write_text(IN_BLENDER)
    process = subprocess.run([addon_package.BLENDER, "-b", "--factory-startup", "--python-exit-code", "1",
                              "--python", str(script), "--", str(addon)],
                             capture_output=True, text=True, timeout=1800)
    lines = [line for line in process.stdout.splitlines() if line.startswith("RESULT ")]
    assert process.returncode == 0 and lines, process.stdout[-3000:] + process.stderr[-3000:]
    out = json.loads(lines[0][len("RESULT "):])
    assert out["cli"] == ["TOY", {"toy_strength": 3.0}]
    assert out["usage"][0] == "--toy-strength is for --method toy"
    # The choices name the toy; Python 3.11 quotes them ('toy'), 3.13 and later do not (toy).
    assert "invalid choice" in out["usage"][1] and re.search(r"choose from .*\btoy\b", out["usage"][1]), out["usage"]
    assert out["validate"] == "toy strength must be in (0, 10], got 50.0"
    assert out["default"] == 2.0
    assert ["prop", "method", ""] in out["drawn"] and ["prop", "toy_strength"] in out["drawn"]
    assert not any("jump_rate" in call or "blend" in call for call in out["drawn"])  # only the toy's section
    assert out["operator"] == ["FINISHED"]
    assert out["runs"] == [["TOY", {"toy_strength": 4.0}, ["Cube"]]]


def test_the_toy_copy_keeps_the_layers(tmp_path):
    """The toy family sits where a method family does, and the layering checks still hold with it."""
    import addon_layers
    addon = str(copy_with_toy(tmp_path))
    layers = dict(addon_layers.LAYERS, toy=addon_layers.LAYERS["surface_colour"])
    assert addon_layers.packages_without_layer(addon, layers) == []
    assert addon_layers.upward_or_sideways_imports(addon, layers) == []
    assert addon_layers.import_circles(addon) == []


def test_a_method_registered_at_run_time_is_validated_through_its_own_check():
    checked = []
    toy = method_spec.MethodSpec("RUNTIME", "runtime", "Runtime", "registered by a test",
                                 validate=lambda settings: checked.append(settings.method))
    family = method_spec.MethodFamily("runtime", (toy,))
    methods.register(family)
    try:
        assert methods.get("RUNTIME") is toy and "RUNTIME" in core_settings.METHODS
        core_settings.Settings(method="RUNTIME").validate()
        assert checked == ["RUNTIME"]
    finally:
        methods.unregister(family)
    assert "RUNTIME" not in core_settings.METHODS
    with pytest.raises(core_settings.SettingsError, match="unknown method"):
        core_settings.Settings(method="RUNTIME").validate()
