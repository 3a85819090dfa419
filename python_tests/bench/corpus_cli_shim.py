# SPDX-License-Identifier: GPL-3.0-or-later
"""Run by bench_corpus.py just before addon/texsynth_cli.py in the same Blender (`--python this --python cli`).

From commit 888d82e to c2e5885 addon/bake/options.py imported `..core.names`, so the CLI's stand-alone load of
it (texsynth_cli._bake_options, module texsynth_cli_bake_options) failed with "attempted relative import with no
known parent package" on every command; the corpus runs were made then. This imports the add-on as the CLI does (package `texsynth` from addon/)
and registers its bake.options under the CLI's module name, so the CLI finds it loaded. Harmless since the fix: the
CLI then finds the same module already loaded."""
import importlib
import importlib.util
import os
import sys

ADDON = os.path.join(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))), "addon")
if "texsynth" not in sys.modules:
    spec = importlib.util.spec_from_file_location("texsynth", os.path.join(ADDON, "__init__.py"),
                                                  submodule_search_locations=[ADDON])
    module = importlib.util.module_from_spec(spec)
    sys.modules["texsynth"] = module
    spec.loader.exec_module(module)
sys.modules.setdefault("texsynth_cli_bake_options", importlib.import_module("texsynth.core.bake_options"))
