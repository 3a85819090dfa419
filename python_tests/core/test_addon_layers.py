# SPDX-License-Identifier: GPL-3.0-or-later
"""The add-on's layering (docs/dev/architecture.md), read from its imports with `ast`, imports inside
functions included: data flows Blender -> bridge -> core/method -> native -> bridge -> Blender, so a
package may import only from its own layer's shared packages below it, never upwards, and no module
takes part in an import circle. The rules: python_tests/addon_layers.py."""
import addon_layers
import paths

ADDON = paths.ADDON


def test_every_package_has_a_layer():
    assert addon_layers.packages_without_layer(ADDON) == []


def test_no_import_reaches_a_higher_layer_or_a_sibling_package():
    wrong = addon_layers.upward_or_sideways_imports(ADDON)
    assert wrong == [], "\n".join(wrong)


def test_the_core_never_imports_blender():
    wrong = addon_layers.blender_imports_in_the_core(ADDON)
    assert wrong == [], "\n".join(wrong)


def test_no_import_circle():
    circles = addon_layers.import_circles(ADDON)
    assert circles == [], "\n".join(circles)


def test_no_file_over_the_line_limit():
    long = addon_layers.long_files(ADDON)
    assert long == [], "\n".join(long)


def test_the_checks_see_a_planted_upward_import_and_circle(tmp_path):
    # The checks above must be able to fail: a bridge module importing the UI is reported, and so is the
    # circle it closes when the UI imports the bridge.
    planted = tmp_path / "addon"
    (planted / "bridge").mkdir(parents=True)
    (planted / "ui").mkdir()
    (planted / "bridge" / "__init__.py").write_text("")
    (planted / "ui" / "__init__.py").write_text("")
    (planted / "ui" / "panels.py").write_text("from ..bridge import mesh_io\nX = 1\n")
    (planted / "bridge" / "mesh_io.py").write_text("def f():\n    from ..ui import panels\n    return panels.X\n")
    assert addon_layers.upward_or_sideways_imports(str(planted)) == [
        "bridge/mesh_io.py:2 imports ui.panels (layer 2 -> 7)"]
    assert addon_layers.import_circles(str(planted)) == ["bridge.mesh_io -> ui.panels -> bridge.mesh_io"]
