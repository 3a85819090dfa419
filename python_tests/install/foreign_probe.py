# SPDX-License-Identifier: GPL-3.0-or-later
"""Run in a foreign runtime after importing a self-contained package's module (blender_envs.sh foreign-check):
prints what answered (build_info) and which shared objects the process mapped, and fails if Embree or
OpenImageIO came from anywhere, or TBB from outside the package."""
import os
import sys

import texsynth_native

package = os.path.abspath(sys.argv[1])
print("foreign-check: module", os.path.relpath(texsynth_native.__file__, package))
print("foreign-check: build_info", texsynth_native.build_info())
with open("/proc/self/maps") as maps_file:
    mapped = sorted({line.split()[-1] for line in maps_file if ".so" in line.split()[-1]})
print("foreign-check: mapped", " ".join(os.path.basename(path) for path in mapped if "python" not in path))
problems = [path for path in mapped if "embree" in path.lower() or "OpenImageIO" in path]
problems += [path for path in mapped if "tbb" in path and not path.startswith(package + "/")]
if problems:
    sys.exit("foreign-check: loaded from outside the package: %s" % " ".join(problems))

# A damaged copy: the package without one of its bundled libraries. The add-on's loader (native.py, bpy-free)
# must name the missing file, not raise.
import glob  # noqa: E402
import shutil  # noqa: E402
import subprocess  # noqa: E402
import tempfile  # noqa: E402

bundled = sorted(glob.glob(os.path.join(package, "texsynth_native.libs", "*")))
if not bundled:
    sys.exit("foreign-check: the package has no texsynth_native.libs/")
damaged = os.path.join(tempfile.mkdtemp(), "texsynth")
shutil.copytree(package, damaged)
os.remove(os.path.join(damaged, "texsynth_native.libs", os.path.basename(bundled[0])))
loader = ("import importlib.util, sys\n"
          "spec = importlib.util.spec_from_file_location('texsynth_loader', sys.argv[1])\n"
          "native = importlib.util.module_from_spec(spec)\n"
          "spec.loader.exec_module(native)\n"
          "print('REASON', native.reason())\n")
result = subprocess.run([sys.executable, "-c", loader, os.path.join(damaged, "native.py")], capture_output=True,
                        text=True, env={"PYTHONPATH": damaged, "PATH": os.environ.get("PATH", "/usr/bin")})
reason = result.stdout.strip()
print("foreign-check: damaged package:", reason)
missing = "texsynth_native.libs/" + os.path.basename(bundled[0])
if result.returncode != 0 or "damaged" not in reason or missing not in reason or "Traceback" in result.stderr:
    sys.exit("foreign-check: a package missing %s did not say so: %s %s" % (missing, reason, result.stderr[-500:]))
shutil.rmtree(os.path.dirname(damaged))
