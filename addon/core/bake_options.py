# SPDX-License-Identifier: GPL-3.0-or-later
"""Bake options without bpy: sizes, margins, target image name or file, writability.

A bake target is either an image name (the image is packed into the .blend, or saved as <name>.png next to
the .blend) or a file path (recognised by a folder separator, a leading "//" or an image extension), where
the image is saved.
"""
import dataclasses
import os

try:
    from .names import fit_name
except ImportError:  # the CLI loads this file on its own, before the add-on (texsynth_cli._standalone)
    import importlib.util

    _names_path = os.path.join(os.path.dirname(os.path.abspath(__file__)), "names.py")
    _names_spec = importlib.util.spec_from_file_location("texsynth_cli_names", _names_path)
    _names = importlib.util.module_from_spec(_names_spec)
    _names_spec.loader.exec_module(_names)
    fit_name = _names.fit_name

BASE_UV_NAME = "TexSynth"  # TexSynth's own UV map (core.layers.BASE_UV_NAME; its islands overlap)
AUTO_UV = "auto"           # CLI --bake-uv auto: the first UV map that is not TexSynth's, else Smart UV Project
SMART_UV_NAME = "UVMap"    # name of the UV map Smart UV Project creates (made unique by Blender if taken)
MIN_SIZE, MAX_SIZE, DEFAULT_SIZE = 8, 8192, 1024
MAX_MARGIN, DEFAULT_MARGIN = 256, 16
IMAGE_PREFIX = "TexSynth Baked: "
MATERIAL_PREFIX = "TexSynth Baked: "
SAVE_MODES = ("PACK", "NEXT_TO_BLEND")
MATERIAL_MODES = ("NONE", "CREATE", "ASSIGN")
FORMATS = {".png": "PNG", ".exr": "OPEN_EXR", ".jpg": "JPEG", ".jpeg": "JPEG", ".tif": "TIFF", ".tiff": "TIFF",
           ".tga": "TARGA"}


class BakeError(ValueError):
    """A bad bake request or a failed bake; nothing was changed."""


@dataclasses.dataclass
class Target:
    image_name: str
    path: str = ""            # "" = packed into the .blend
    file_format: str = "PNG"

    @property
    def float_buffer(self):
        return self.file_format == "OPEN_EXR"


@dataclasses.dataclass
class BakeRequest:
    target: str = ""          # image name or file path ("" = "TexSynth Baked: <object>")
    uv_map: str = ""          # "" or "auto": the first non-TexSynth UV map (create one if allowed)
    size: int = DEFAULT_SIZE
    margin: int = DEFAULT_MARGIN
    save_mode: str = "PACK"   # for image names: PACK, or NEXT_TO_BLEND (<name>.png next to the saved .blend)
    create_uv: bool = False   # no UV map besides TexSynth's: make one with Smart UV Project
    material: str = "NONE"    # NONE, CREATE "TexSynth Baked: <object>", or ASSIGN it to the object too
    samples: int = 4          # Cycles samples per texel (box filter; the emission is deterministic)

    def validate(self):
        """Raises BakeError naming the first bad option; returns self."""
        check_size(self.size)
        check_margin(self.margin, self.size)
        if self.uv_map == BASE_UV_NAME:
            raise BakeError(uv_refusal())
        if self.save_mode not in SAVE_MODES:
            raise BakeError("unknown save mode %r (choose one of %s)" % (self.save_mode, ", ".join(SAVE_MODES)))
        if self.material not in MATERIAL_MODES:
            raise BakeError("unknown bake material mode %r (choose one of %s)"
                            % (self.material, ", ".join(MATERIAL_MODES)))
        if not (isinstance(self.samples, int) and 1 <= self.samples <= 64):
            raise BakeError("bake samples must be an integer in [1, 64], got %r" % (self.samples,))
        return self

    @property
    def auto_uv(self):
        return self.uv_map in ("", AUTO_UV)


def uv_refusal():
    return ("cannot bake through TexSynth's own UV map %r: its islands overlap (every face maps into the "
            "sample); choose another UV map or let TexSynth create one (Smart UV Project)" % BASE_UV_NAME)


def _is_int(value):
    return isinstance(value, int) and not isinstance(value, bool)


def check_size(size):
    if not _is_int(size) or not MIN_SIZE <= size <= MAX_SIZE:
        raise BakeError("bake size must be an integer in [%d, %d] pixels, got %r" % (MIN_SIZE, MAX_SIZE, size))
    return size


def check_margin(margin, size=MAX_SIZE):
    if not _is_int(margin) or not 0 <= margin <= min(MAX_MARGIN, size // 2):
        raise BakeError("bake margin must be an integer in [0, %d] pixels, got %r"
                        % (min(MAX_MARGIN, size // 2), margin))
    return margin


def looks_like_path(target):
    return ("/" in target or "\\" in target or os.sep in target
            or os.path.splitext(target)[1].lower() in FORMATS)


def resolve_target(target, object_name, save_mode="PACK", blend_path=""):
    """Target for an image name or an (absolute) file path; blend_path = the saved .blend ("" if unsaved)."""
    target = (target or "").strip()
    if target and looks_like_path(target):
        path = os.path.abspath(target)
        extension = os.path.splitext(path)[1].lower()
        if extension not in FORMATS:
            raise BakeError("unsupported bake image type %r (use %s)" % (extension or path, ", ".join(sorted(FORMATS))))
        check_writable(path)
        return Target(os.path.basename(path), path, FORMATS[extension])
    name = target or fit_name(IMAGE_PREFIX, object_name)
    if save_mode == "NEXT_TO_BLEND":
        if not blend_path:
            raise BakeError("save the .blend first to save the baked image next to it (or pack it)")
        path = os.path.join(os.path.dirname(os.path.abspath(blend_path)), safe_file_name(name) + ".png")
        check_writable(path)
        return Target(name, path, "PNG")
    return Target(name)


def safe_file_name(name):
    cleaned = "".join(c if c.isalnum() or c in "-_. " else "_" for c in name).strip(" .")
    return cleaned or "texsynth_baked"


def check_writable(path):
    """Raises BakeError unless a file can be written at path (folder exists and is writable)."""
    folder = os.path.dirname(os.path.abspath(path))
    if os.path.isdir(path):
        raise BakeError("bake path is a folder: %s" % path)
    if not os.path.isdir(folder):
        raise BakeError("bake folder does not exist: %s" % folder)
    if not os.access(folder, os.W_OK | os.X_OK) or (os.path.exists(path) and not os.access(path, os.W_OK)):
        raise BakeError("bake path is not writable: %s" % path)
    return path


# Smart UV Project's angle limit for the UV maps TexSynth makes: Blender's default 66° folds a few faces
# onto their neighbours on curved meshes (78 of 109k texels twice covered on Suzanne, subdivision 2, at
# 512²; 684 at 1024², subdivision 3); 45° gave none there (python_tests/bench/bench_round_quality.py).
SMART_UV_ANGLE_DEGREES = 45.0
# Gap between the islands of a new UV map, in texels of the image. Smart UV Project's own island margin is
# a fraction of UV space per island: the old 2 x bake margin / size left 94 % of a 1024² image empty on the
# 75k-face Stanford bunny (1,900 islands). Islands are now packed 2 texels apart (6 % -> 44-49 % used,
# 168 -> 444-465 texels per unit; docs/dev/uv_packing.md); the bake's margin fills those gaps.
PACK_GAP_TEXELS = 2


def pack_margin(size):
    """pack_islands' margin (a fraction of UV space) that leaves PACK_GAP_TEXELS between islands."""
    return PACK_GAP_TEXELS / float(size) if size > 0 else 0.0
