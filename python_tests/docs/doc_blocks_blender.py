# SPDX-License-Identifier: GPL-3.0-or-later
"""Runs the docs' bpy code blocks inside one Blender, with the add-on from addon/ registered as `texsynth`.

blender -b --factory-startup --python-exit-code 1 --python <this> -- BLOCKS.json
BLOCKS.json: [{"name": "docs/x.md:12", "file": "docs/x.md", "line": 12, "source": "..."}, ...]

Prints "CLI_OPTIONS <json list>" (the options addon/texsynth_cli.py accepts, for the sh-block check), then per
block "BLOCK PASS <name>" or "BLOCK FAIL <name>" with its traceback under it, and a last "BLOCKS DONE" line.
"""
import json
import os
import sys
import tempfile
import traceback

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(os.path.dirname(HERE), "blender"))
sys.path.insert(0, HERE)
import bpy  # noqa: E402

import cli_options  # noqa: E402
import harness  # noqa: E402


def report_cli_options():
    try:
        options = sorted(cli_options.texsynth_cli_options(harness.ADDON_DIR))
    except Exception:
        traceback.print_exc(file=sys.stdout)
        options = None
    print("CLI_OPTIONS " + json.dumps(options), flush=True)


def run_block(block):
    # A fresh scene, folder and namespace per block: a block sees only what it makes itself.
    harness.reset_scene()
    os.chdir(tempfile.mkdtemp(prefix="texsynth_doc_block_"))
    # Leading newlines: tracebacks then name the doc file and its own line numbers.
    code = compile("\n" * block["line"] + block["source"], block["file"], "exec")
    exec(code, {"__name__": "__main__"})


def main():
    blocks = json.load(open(sys.argv[sys.argv.index("--") + 1]))
    report_cli_options()
    texsynth = harness.load_addon()
    texsynth.register()
    for block in blocks:
        try:
            run_block(block)
            print("BLOCK PASS", block["name"], flush=True)
        except Exception:
            print("BLOCK FAIL", block["name"], flush=True)
            traceback.print_exc(file=sys.stdout)
            sys.stdout.flush()
    print("BLOCKS DONE", flush=True)


main()
