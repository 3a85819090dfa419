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
