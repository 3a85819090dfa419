# SPDX-License-Identifier: GPL-3.0-or-later
"""The same outputs on every x86-64 CPU: every method's outputs (python_tests/blender/output_digest.py,
through the CLI's code path inside Blender) are hashed with every run-time dispatch varied that this
machine can vary, and must not change:
- the cache sizes Eigen reads with cpuid and sizes its matrix-product blocks from (set as an AMD
  Zen 4 and as a small-L1 CPU report them): the cause of the cross-machine difference (issue 34);
- glibc's dispatch of libm and string functions (GLIBC_TUNABLES: the x86-64 baseline, no AVX/FMA);
- the thread count (TBB follows the CPU affinity: one CPU against all of them).
Embree (its own ISA dispatch) is not on any synthesis path; no BLAS routine is called.
docs/dev/determinism.md has the measurements."""
import json
import os

import pytest

import addon_package
import blender_run

SCRIPT = os.path.join(blender_run.BLENDER_TESTS, "output_digest.py")
ZEN4_CACHES = ("32768", "1048576", "33554432")
SMALL_L1_CACHES = ("16384", "524288", "4194304")
# glibc 2.36 names; the variant is checked to take effect below (ld.so --list-diagnostics).
BASELINE_ISA = "glibc.cpu.hwcaps=-AVX512F,-AVX2,-FMA,-AVX,-SSE4_2,-SSE4_1"

pytestmark = pytest.mark.skipif(not addon_package.real_synthesizer_available(),
                                reason="needs the built texsynth_native")


def digests(*script_args, env=None, prefix=()):
    args = ["--python", SCRIPT, "--"] + list(script_args)
    if prefix:  # e.g. taskset: run Blender itself under it
        command_env = dict(os.environ)
        command_env.update(env or {})
        import subprocess

        command = list(prefix) + [addon_package.BLENDER, "-b", "--factory-startup", "--python-exit-code", "1"] + args
        process = subprocess.run(command, cwd=blender_run.ROOT, capture_output=True, text=True, timeout=blender_run.HANG_SECONDS,
                                 env=command_env)
    else:
        process = blender_run.blender(*args, env=env, timeout=blender_run.HANG_SECONDS)
    lines = [line for line in process.stdout.splitlines() if line.startswith("DIGEST ")]
    assert process.returncode == 0 and lines, process.stdout[-3000:] + process.stderr[-3000:]
    return json.loads(lines[-1][len("DIGEST "):])


def glibc_platform(env):
    import subprocess

    ld = "/lib64/ld-linux-x86-64.so.2"
    full = dict(os.environ)
    full.update(env)
    output = subprocess.run([ld, "--list-diagnostics"], capture_output=True, text=True, env=full).stdout
    return [line for line in output.splitlines() if line.startswith("dl_platform=")]


def test_every_method_gives_the_same_outputs_whatever_the_cpu_dispatch():
    baseline = digests()
    assert set(baseline) == {"jumpmap", "texton", "round", "patches", "particles"}
    variants = {"Zen 4 caches, x86-64 baseline ISA in glibc": (("--cache-sizes",) + ZEN4_CACHES,
                                                               {"GLIBC_TUNABLES": BASELINE_ISA}, ())}
    if len(os.sched_getaffinity(0)) > 1:
        cpu = str(min(os.sched_getaffinity(0)))
        variants["small L1, one thread"] = (("--cache-sizes",) + SMALL_L1_CACHES, {}, ("taskset", "-c", cpu))
    else:
        variants["small L1"] = (("--cache-sizes",) + SMALL_L1_CACHES, {}, ())
    # The glibc variant must really change the dispatch (else the check proves nothing).
    assert glibc_platform({"GLIBC_TUNABLES": BASELINE_ISA}) != glibc_platform({}) or \
        glibc_platform({}) == ['dl_platform="x86_64"'], "GLIBC_TUNABLES had no effect"
    for name, (args, env, prefix) in variants.items():
        got = digests(*args, env=env, prefix=prefix)
        changed = {m: (baseline[m], got[m]) for m in baseline if got[m] != baseline[m]}
        assert not changed, "%s changed the outputs of %s" % (name, changed)
    print("output digests:", json.dumps(baseline, sort_keys=True))
