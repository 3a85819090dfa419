# SPDX-License-Identifier: GPL-3.0-or-later
"""The ONE place that imports the compiled module texsynth_native.

Imported lazily and never raising: enabling the add-on must not fail when the module is missing,
built for another Python, or fails to load. `reason()` says why it is unavailable (the panel shows it).
TEXSYNTH_MODULE_DIR (e.g. a sanitizer build) is searched first, like the tests do.
"""
import glob
import importlib
import os
import re
import sys
import sysconfig

MODULE_NAME = "texsynth_native"
_PACKAGE_DIR = os.path.dirname(os.path.abspath(__file__))

_module = None
_reason = None
_tried = False


class NativeUnavailable(RuntimeError):
    """The compiled module cannot be used; the message says why and how to fix it."""


def _expected_suffix():
    return sysconfig.get_config_var("EXT_SUFFIX") or ".so"


def diagnose(folder=_PACKAGE_DIR, suffix=None, version_info=None):
    """Why texsynth_native in `folder` cannot load for this interpreter, or None if a matching file exists."""
    suffix = suffix or _expected_suffix()
    version_info = version_info or sys.version_info
    candidates = sorted(glob.glob(os.path.join(folder, MODULE_NAME + "*.so")) +
                        glob.glob(os.path.join(folder, MODULE_NAME + "*.pyd")))
    if not candidates:
        return ("native module missing: no %s*.so in %s (build it with scripts/build.sh)" % (MODULE_NAME, folder))
    if not any(os.path.basename(c) == MODULE_NAME + suffix for c in candidates):
        found = ", ".join(os.path.basename(c) for c in candidates)
        return ("native module built for another Python: found %s, but this Blender runs Python %d.%d "
                "and needs %s%s (rebuild with scripts/build.sh)"
                % (found, version_info[0], version_info[1], MODULE_NAME, suffix))
    return None


def explain_load_error(error):
    """A one-line reason for an ImportError/OSError raised while loading the module: which shared
    library is missing, or which symbol does not resolve (a library of another version)."""
    text = str(error)
    missing = re.search(r"([\w.+-]+\.so[\w.]*): cannot open shared object file", text)
    if missing:
        return ("native module needs the shared library %s, which this system does not have: install the "
                "package that provides it (Debian's blender package pulls in OpenImageIO, Embree and TBB), "
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
