#!/usr/bin/env python3
# SPDX-License-Identifier: GPL-3.0-or-later
"""What a self-contained texsynth_native would weigh: the module plus every shared library it loads
that a Blender from blender.org cannot be assumed to provide (what auditwheel would copy in), broken
down by the module's direct dependencies (each with everything it loads in turn).

Usage: python3 scripts/measure_bundle.py MODULE.so
The manylinux policy's system libraries (glibc, libstdc++, libgcc_s, zlib) stay out.
"""
import os
import re
import subprocess
import sys

SYSTEM = re.compile(r"^(linux-vdso|ld-linux|libc|libm|libdl|libpthread|librt|libutil|libstdc\+\+|libgcc_s|"
                    r"libresolv|libnsl|libcrypt|libz)\.so")


def closure(path):
    """{soname: real path} of every non-system library `path` loads, directly or not (ldd)."""
    output = subprocess.run(["ldd", path], capture_output=True, text=True, check=True).stdout
    found = {}
    for line in output.splitlines():
        match = re.match(r"\s*(\S+) => (\S+)", line)
        if match and not SYSTEM.match(match.group(1)) and os.path.exists(match.group(2)):
            found[match.group(1)] = os.path.realpath(match.group(2))
    return found


def direct_needs(path):
    output = subprocess.run(["objdump", "-p", path], capture_output=True, text=True, check=True).stdout
    return re.findall(r"NEEDED\s+(\S+)", output)


def megabytes(paths):
    return sum(os.path.getsize(p) for p in paths) / 1e6


def main(module):
    everything = closure(module)
    print("module %s: %.1f MB" % (os.path.basename(module), os.path.getsize(module) / 1e6))
    counted = set()
    for need in direct_needs(module):
        if need not in everything:
            continue
        mine = {need: everything[need]}
        mine.update(closure(everything[need]))
        new = {name: path for name, path in mine.items() if name not in counted}
        counted.update(new)
        print("  %-28s %3d libraries %7.1f MB" % (need, len(new), megabytes(new.values())))
    rest = {name: path for name, path in everything.items() if name not in counted}
    if rest:
        print("  %-28s %3d libraries %7.1f MB" % ("(other)", len(rest), megabytes(rest.values())))
    total = megabytes(everything.values())
    print("self-contained: %d libraries, %.1f MB uncompressed (module + %.1f MB of libraries)"
          % (len(everything), os.path.getsize(module) / 1e6 + total, total))


if __name__ == "__main__":
    main(sys.argv[1])
