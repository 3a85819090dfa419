# SPDX-License-Identifier: GPL-3.0-or-later
"""The ONE place that imports the compiled module texsynth_native.

Imported lazily and never raising: enabling the add-on must not fail when the module is missing,
built for another Python, or fails to load. `reason()` says why it is unavailable (the panel shows it).
TEXSYNTH_MODULE_DIR (e.g. a sanitizer build) is searched first, like the tests do.

Self-contained packages (blender.org builds) carry their libraries in texsynth_native.libs/. They are imported
with the default flags, not RTLD_DEEPBIND: that would bind the module's malloc/free to glibc's while Blender
allocates with jemalloc (measured: an abort at the first call). Nothing needs it: Embree and the C++ runtime are
static and hidden, and the bundled TBB 2020 shares no symbol the module uses with Blender's oneTBB
(docs/dev/blender_org_packages.md).
"""
import glob
import importlib
import os
import re
import sys
import sysconfig

MODULE_NAME = "texsynth_native"
LIBS_DIR_NAME = MODULE_NAME + ".libs"
_PACKAGE_DIR = os.path.dirname(os.path.abspath(__file__))

_module = None
_reason = None
_tried = False


class NativeUnavailable(RuntimeError):
    """The compiled module cannot be used; the message says why and how to fix it."""


def _expected_suffix():
    return sysconfig.get_config_var("EXT_SUFFIX") or ".so"


_PLATFORMS = (("linux", "Linux"), ("darwin", "macOS"), ("win", "Windows"))


def built_for(filename):
    """'Python 3.13 on Linux' for texsynth_native.cpython-313-x86_64-linux-gnu.so (None parts left out)."""
    python = re.search(r"\.c(?:python-|p)3(\d+)", filename)
    platform = next((label for key, label in _PLATFORMS if key in filename.lower()), None)
    if filename.endswith(".pyd"):
        platform = "Windows"
    parts = ["Python 3.%s" % python.group(1)] if python else ["an unknown Python"]
    return " on ".join(parts + ([platform] if platform else []))


def diagnose(folder=_PACKAGE_DIR, suffix=None, version_info=None, platform=None):
    """Why texsynth_native in `folder` cannot load for this interpreter, or None if a matching file exists."""
    suffix = suffix or _expected_suffix()
    version_info = version_info or sys.version_info
    platform = platform or sys.platform
    candidates = sorted(glob.glob(os.path.join(folder, MODULE_NAME + "*.so")) +
                        glob.glob(os.path.join(folder, MODULE_NAME + "*.pyd")))
    if not candidates:
        return ("native module missing: no %s*.so in %s (build it with scripts/build.sh)" % (MODULE_NAME, folder))
    if not any(os.path.basename(c) == MODULE_NAME + suffix for c in candidates):
        found = ", ".join(os.path.basename(c) for c in candidates)
        here = "Python %d.%d on %s" % (version_info[0], version_info[1],
                                       next((label for key, label in _PLATFORMS if platform.startswith(key)), platform))
        builds = sorted({built_for(os.path.basename(c)) for c in candidates})
        return ("native module built for another Python: this TexSynth package is built for %s (%s), but this "
                "Blender runs %s and needs %s%s: install the TexSynth package for %s (or rebuild with "
                "scripts/build.sh)" % (" and ".join(builds), found, here, MODULE_NAME, suffix, here))
    return None


def explain_load_error(error, folder=_PACKAGE_DIR):
    """A one-line reason for an ImportError/OSError raised while loading the module: which shared
    library is missing, or which symbol does not resolve (a library of another version)."""
    text = str(error)
    missing = re.search(r"([\w.+-]+\.so[\w.]*): cannot open shared object file", text)
    if missing and os.path.isdir(os.path.join(folder, LIBS_DIR_NAME)):
        # A self-contained package brings its libraries: one that is absent means the package is damaged.
        return ("the TexSynth package is damaged: %s/%s is missing from %s; reinstall the package"
                % (LIBS_DIR_NAME, missing.group(1), folder))
    if missing:
        return ("native module needs the shared library %s, which this system does not have: install the "
                "package that provides it (Debian's blender package pulls in Embree and TBB), "
                "or use the TexSynth package built for this Blender" % missing.group(1))
    symbol = re.search(r"undefined symbol: (\S+)", text)
    if symbol:
        return ("native module does not match this system's libraries (undefined symbol %s): it was built "
                "against other versions; use the TexSynth package built for this Blender or rebuild it "
                "with scripts/build.sh" % symbol.group(1))
    return "native module failed to load: %s" % text


def _try_import():
    override = os.environ.get("TEXSYNTH_MODULE_DIR")
    if override and os.path.isdir(override):
        if override not in sys.path:
            sys.path.insert(0, override)
        return importlib.import_module(MODULE_NAME)
    package = __package__ or __name__.rpartition(".")[0]
    if package:
        return importlib.import_module("." + MODULE_NAME, package)
    return importlib.import_module(MODULE_NAME)


def get():
    """The module, or None (see reason())."""
    global _module, _reason, _tried
    if not _tried:
        _tried = True
        try:
            _module = _try_import()
        except (ImportError, OSError) as error:
            _reason = diagnose() or explain_load_error(error)
            _module = None
    return _module


def reason():
    """Why the module is unavailable ('' when it is available)."""
    get()
    return _reason or ""


def require():
    """The module, or NativeUnavailable with the reason."""
    module = get()
    if module is None:
        raise NativeUnavailable(_reason)
    return module
