# SPDX-License-Identifier: GPL-3.0-or-later
"""The --options a command-line entry point accepts, read from the argparse parser it builds.

Plain Python, also imported inside Blender by doc_blocks_blender.py (addon/texsynth_cli.py imports bpy).
Only the entry point's public function is called (texsynth_cli.build_parser() when it exists, else
texsynth_cli.parse_args / texsynth_batch.main): the parser is taken at its first parse, so options that a
method registry adds while building it are included, and nothing else of the module's insides is assumed.
"""
import argparse
import contextlib
import importlib.util
import os
import sys


class _Captured(Exception):
    pass


def load_module(path, name):
    """The file imported under `name` (not __main__, so its command-line entry does not run)."""
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    return module


def walk_options(parser):
    """Every option string of parser and of its sub-commands' parsers."""
    found = set()
    for action in parser._actions:
        found.update(s for s in action.option_strings if s.startswith("--"))
        if isinstance(action, argparse._SubParsersAction):
            for sub in action.choices.values():
                found |= walk_options(sub)
    return found


@contextlib.contextmanager
def _first_parser(captured):
    # parse_args goes through parse_known_args in every Python 3 argparse: stop there with the parser built.
    original = argparse.ArgumentParser.parse_known_args

    def capture(self, *args, **kwargs):
        captured.append(self)
        raise _Captured()

    argparse.ArgumentParser.parse_known_args = capture
    try:
        yield
    finally:
        argparse.ArgumentParser.parse_known_args = original


def parser_options(function, *args):
    """The options of the parser that function(*args) builds and parses with."""
    captured = []
    with _first_parser(captured):
        try:
            function(*args)
        except _Captured:
            pass
    if not captured:
        raise RuntimeError("%s parsed no arguments" % getattr(function, "__name__", function))
    return walk_options(captured[0])


def texsynth_cli_options(addon_dir):
    module = load_module(os.path.join(addon_dir, "texsynth_cli.py"), "texsynth_cli_for_docs")
    build = getattr(module, "build_parser", None)
    if build is not None:
        return walk_options(build())
    return parser_options(module.parse_args, [])


def texsynth_batch_options(addon_dir):
    module = load_module(os.path.join(addon_dir, "texsynth_batch.py"), "texsynth_batch_for_docs")
    return parser_options(module.main, ["run", "jobs.json"])
