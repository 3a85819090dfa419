# SPDX-License-Identifier: GPL-3.0-or-later
"""python_tests/install/native_calls.py, the foreign-runtime stage's comparison script: two runs in fresh
processes save the same bytes under every key, and `compare` fails (exit 1) on a single changed bit, a
missing key or another dtype, while --exact limits the keys that must match."""
import os
import subprocess
import sys

import numpy as np
import pytest
import paths

tn = pytest.importorskip("texsynth_native")

SCRIPT = os.path.join(paths.INSTALL_SCRIPTS, "native_calls.py")
SUMMARY = "native_calls: "


def script(*args):
    env = dict(os.environ)
    # Only the module's own directory: the script must not need the add-on or the test helpers.
    env["PYTHONPATH"] = os.path.dirname(os.path.abspath(tn.__file__))
    return subprocess.run([sys.executable, SCRIPT] + [str(a) for a in args], capture_output=True, text=True,
                          timeout=300, env=env, cwd=os.path.dirname(SCRIPT))


def summary(process):
    lines = [line for line in process.stdout.splitlines() if line.startswith(SUMMARY)]
    assert len(lines) == 1, process.stdout[-3000:] + process.stderr[-3000:]
    return lines[0]


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    directory = tmp_path_factory.mktemp("native_calls")
    paths = []
    for name in ("a.npz", "b.npz"):
        path = directory / name
        process = script("run", path)
        assert process.returncode == 0, process.stdout[-3000:] + process.stderr[-3000:]
        paths.append(path)
    return paths


def test_two_runs_are_equal_bit_for_bit(runs):
    a, b = runs
    with np.load(a) as saved:
        keys = set(saved.files)
        assert str(saved["version"]) == tn.__version__
    for prefix in ("jumpmap.", "texton.", "round.", "patches.", "particles.", "decals.", "raycast.", "field.",
                   "histogram.cached."):
        assert any(k.startswith(prefix) for k in keys), prefix
    assert not any("seconds" in k for k in keys)
    process = script("compare", a, b)
    assert process.returncode == 0, process.stdout[-3000:]
    assert summary(process) == "%s%d keys, %d equal, 0 differ" % (SUMMARY, len(keys), len(keys))


def perturbed(source, target, key, change):
    with np.load(source) as saved:
        arrays = {k: saved[k] for k in saved.files}
    change(arrays, key)
    np.savez(target, **arrays)


def one_ulp(arrays, key):
    array = arrays[key].copy()
    flat = array.reshape(-1)
    flat[7] = np.nextafter(flat[7], np.float32(np.inf))
    arrays[key] = array


def test_compare_fails_on_one_changed_value_unless_the_key_is_tolerated(runs, tmp_path):
    a, _ = runs
    changed = tmp_path / "changed.npz"
    perturbed(a, changed, "round.colour", one_ulp)
    process = script("compare", a, changed)
    assert process.returncode == 1, process.stdout[-3000:]
    line = next(l for l in process.stdout.splitlines() if l.startswith("round.colour "))
    assert "1 of" in line and "differ" in line, line
    assert summary(process).endswith(" 1 differ")
    # Not in the exact set: reported, tolerated.
    process = script("compare", a, changed, "--exact", "jumpmap.", "texton.")
    assert process.returncode == 0, process.stdout[-3000:]
    assert "(tolerated)" in process.stdout and summary(process).endswith(" 1 differ")
    process = script("compare", a, changed, "--exact", "round.")
    assert process.returncode == 1


def test_a_tolerance_bounds_the_difference_and_leaves_other_keys_exact(runs, tmp_path):
    """How the blender.org stage compares ray casts (Embree's SSE2 kernels round differently): a tolerated key
    passes within its bound and fails above it; every other key stays exact."""
    a, _ = runs
    changed = tmp_path / "changed.npz"
    perturbed(a, changed, "round.colour", one_ulp)
    within = script("compare", a, changed, "--tolerance", "round.=1e-3")
    assert within.returncode == 0 and "(within 0.001)" in within.stdout, within.stdout[-3000:]
    above = script("compare", a, changed, "--tolerance", "round.=1e-12")
    assert above.returncode == 1 and "(ABOVE 1e-12)" in above.stdout, above.stdout[-3000:]
    elsewhere = script("compare", a, changed, "--tolerance", "raycast.=1e-3")
    assert elsewhere.returncode == 1, elsewhere.stdout[-3000:]


@pytest.mark.parametrize("change", ["missing", "dtype"])
def test_compare_fails_on_a_missing_key_or_another_dtype(runs, tmp_path, change):
    a, _ = runs
    other = tmp_path / "other.npz"
    if change == "missing":
        perturbed(a, other, "raycast.face", lambda arrays, key: arrays.pop(key))
    else:
        perturbed(a, other, "raycast.face", lambda arrays, key: arrays.__setitem__(key, arrays[key].astype(np.int64)))
    # Even when the key is outside the exact set.
    process = script("compare", a, other, "--exact", "jumpmap.")
    assert process.returncode == 1, process.stdout[-3000:]
    assert "raycast.face" in process.stdout and summary(process).endswith(" 1 differ")
