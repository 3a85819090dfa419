# SPDX-License-Identifier: GPL-3.0-or-later
"""Runs addon/texsynth_cli.py with the contract double fake_native.py in place of texsynth_native
(used by the CLI tests only while the real synthesizer is not built)."""
import os
import runpy
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import fake_native  # noqa: E402
import harness  # noqa: E402

addon = harness.load_addon()
addon.native._module, addon.native._reason, addon.native._tried = fake_native, None, True
cli = os.path.join(harness.ADDON_DIR, "texsynth_cli.py")
sys.argv[0] = cli
runpy.run_path(cli, run_name="__main__")
