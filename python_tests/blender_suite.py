# SPDX-License-Identifier: GPL-3.0-or-later
"""Blender-side suites (python_tests/blender/tests_*.py) as one pytest case per check.

Each suite runs once per pytest session in one Blender process (starting Blender per check would cost
minutes); every check it defines becomes its own case, read from the suite's source with `ast` (the suite
imports bpy). A check that failed shows its traceback under its own name; a check the suite never
reported (a crash, an exit before it, a rename) fails by name too, so no check can be lost silently."""
import ast
import re

import blender_run

_runs = {}
_LINE = re.compile(r"^(PASS|FAIL) (test_\w+)$")


def check_names(script, exclude=()):
    """The suite's checks: its top-level functions named test_*, in source order."""
    tree = ast.parse(open(script).read())
    return [node.name for node in tree.body
            if isinstance(node, ast.FunctionDef) and node.name.startswith("test_") and node.name not in exclude]


def module_constant(script, name):
    """A literal the suite defines at top level (e.g. a tuple of check names), without importing bpy."""
    tree = ast.parse(open(script).read())
    return next(ast.literal_eval(node.value) for node in tree.body
                if isinstance(node, ast.Assign) and getattr(node.targets[0], "id", "") == name)


class SuiteRun:
    """What one Blender run of a suite printed: per check, PASS or FAIL and the text printed after it."""

    def __init__(self, process):
        self.returncode = process.returncode
        self.output = process.stdout + "\n" + process.stderr
        self.results = {}
        current = None
        for line in process.stdout.splitlines():
            match = _LINE.match(line.strip())
            if match:
                current = match.group(2)
                self.results[current] = [match.group(1), []]
            elif line.startswith("SUMMARY "):
                current = None
            elif current is not None:
                self.results[current][1].append(line)
        self.finished = "SUMMARY failed=" in process.stdout

    def details(self, name):
        status, lines = self.results[name]
        # The harness prints the traceback on stderr: show the end of both streams with the check's own lines.
        return "\n".join(lines[-60:]) + "\n--- end of the suite's output ---\n" + self.output[-4000:]


def run(script, *names, env=None):
    """The suite's run (cached per script, checks and environment); names: only these checks."""
    key = (script, names, tuple(sorted((env or {}).items())))
    if key not in _runs:
        args = ("--python", script) + (("--",) + names if names else ())
        _runs[key] = SuiteRun(blender_run.blender(*args, env=env))
    return _runs[key]


def assert_check(script, name, *names, env=None):
    """Fails unless the suite's run reported `name` as passed."""
    result = run(script, *names, env=env)
    if name not in result.results:
        raise AssertionError("the suite never reported %s (exit code %d%s):\n%s"
                             % (name, result.returncode, "" if result.finished else ", no SUMMARY line",
                                result.output[-6000:]))
    if result.results[name][0] != "PASS":
        raise AssertionError("%s failed inside Blender:\n%s" % (name, result.details(name)))
