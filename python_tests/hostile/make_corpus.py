# SPDX-License-Identifier: GPL-3.0-or-later
"""Generates the hostile-input corpus (meshes, images, parameters, caches) into a folder.

    python3.11 python_tests/hostile/make_corpus.py OUT_DIR      # writes files + OUT_DIR/cases.json

Every case is a JSON dict: id, kind (image | array | preprocess | cache | mesh | synth), the inputs
(files relative to OUT_DIR, parameters) and `expect`: "error" (must raise a clear error), "ok" (must
return a valid result) or "either". Nothing here is hand-collected: files are written byte by byte
(PNG/TIFF/PFM writers below) or with oiiotool (openimageio-tools), caches with texsynth_native.
Set TEXSYNTH_HOSTILE_HUGE=1 to add the 10 M-face mesh (built by the worker at run time).
"""
import json
import os
import random
import struct
import subprocess
import sys
import zlib

import numpy as np

SAMPLE_SIZE = 32           # the small valid sample every mesh/param case synthesizes from
SMALL_PARAMS = dict(neighbourhood=3, num_textons=6, feature_dims=6)
HUGE_FACES = 10_000_000


# ---------------------------------------------------------------- image writers (byte-exact, no library)

def _png_chunk(kind, data):
    return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)


def png_bytes(width, height, color_type, bit_depth, rows, palette=None):
    """rows: bytes of the raw (unfiltered) scanlines, or a callable giving one row (for huge images)."""
    header = struct.pack(">IIBBBBB", width, height, bit_depth, color_type, 0, 0, 0)
    out = [b"\x89PNG\r\n\x1a\n", _png_chunk(b"IHDR", header)]
    if palette is not None:
        out.append(_png_chunk(b"PLTE", palette))
    compressor = zlib.compressobj(9)
    idat = []
    for y in range(height):
        idat.append(compressor.compress(b"\x00" + (rows(y) if callable(rows) else rows[y])))
    idat.append(compressor.flush())
    out += [_png_chunk(b"IDAT", b"".join(idat)), _png_chunk(b"IEND", b"")]
    return b"".join(out)


def png_from_array(array):
    """uint8/uint16 H x W x C (C = 1..4) -> PNG bytes."""
    height, width, channels = array.shape
    color_type = {1: 0, 2: 4, 3: 2, 4: 6}[channels]
    depth = 16 if array.dtype == np.uint16 else 8
    data = array.astype(">u2") if depth == 16 else array
    return png_bytes(width, height, color_type, depth, [data[y].tobytes() for y in range(height)])


def pfm_bytes(array):
    """float32 H x W x 3 -> PFM (row 0 at the bottom, little endian)."""
    height, width, _ = array.shape
    return b"PF\n%d %d\n-1.0\n" % (width, height) + np.ascontiguousarray(array[::-1], dtype="<f4").tobytes()


def sample_pixels(size=SAMPLE_SIZE, seed=7):
    """A texture-like uint8 RGB sample: stripes + value noise (deterministic)."""
    rng = np.random.default_rng(seed)
    y, x = np.mgrid[0:size, 0:size]
    stripes = (np.sin(x * 0.7 + y * 0.2) * 0.5 + 0.5)[..., None]
    noise = rng.random((size, size, 3))
    return np.clip((0.7 * stripes + 0.3 * noise) * 255, 0, 255).astype(np.uint8)


def oiiotool(*args):
    subprocess.run(["oiiotool", *args], check=True, capture_output=True)


# ---------------------------------------------------------------- meshes

def grid(nx, ny, triangles=False, spacing=1.0, offset=(0.0, 0.0, 0.0)):
    xs, ys = np.meshgrid(np.arange(nx + 1), np.arange(ny + 1))
    positions = np.stack([xs.ravel() * spacing, ys.ravel() * spacing, np.zeros(xs.size)], 1) + offset
    v = lambda x, y: y * (nx + 1) + x  # noqa: E731
    polys = []
    for y in range(ny):
        for x in range(nx):
            quad = [v(x, y), v(x + 1, y), v(x + 1, y + 1), v(x, y + 1)]
            polys += [quad[:3], [quad[0], quad[2], quad[3]]] if triangles else [quad]
    return positions.astype(np.float32), polys


def mesh_arrays(positions, polys):
    sizes = np.array([len(p) for p in polys], dtype=np.int32)
    starts = np.concatenate([[0], np.cumsum(sizes)[:-1]]).astype(np.int32) if len(polys) else np.zeros(0, np.int32)
    corners = np.array([i for p in polys for i in p], dtype=np.int32)
    return dict(positions=np.asarray(positions, dtype=np.float32).reshape(-1, 3), corner_verts=corners,
                poly_starts=starts, poly_sizes=sizes)


def ngon(center, radius, n, start_index):
    angles = np.linspace(0, 2 * np.pi, n, endpoint=False)
    pts = np.stack([center[0] + radius * np.cos(angles), center[1] + radius * np.sin(angles), np.zeros(n)], 1)
    return pts, [list(range(start_index, start_index + n))]


def hostile_meshes():
    """name -> (arrays dict, expect). Every array is Blender's layout (see poly_mesh.hpp)."""
    meshes = {}
    g_pos, g_polys = grid(4, 4)
    ok = lambda p, f: (mesh_arrays(p, f), "ok")  # noqa: E731
    # Nothing to map is a valid (empty) result natively; the add-on refuses faceless meshes itself.
    meshes["empty"] = ok(np.zeros((0, 3)), [])
    meshes["one_vertex"] = ok(np.zeros((1, 3)), [])
    meshes["loose_edges_only"] = ok(g_pos, [])
    meshes["grid_quads"] = ok(g_pos, g_polys)
    meshes["grid_tris"] = ok(*grid(4, 4, triangles=True))
    meshes["zero_area_faces"] = ok(np.array([[0, 0, 0], [0, 0, 0], [0, 0, 0], [1, 1, 0], [2, 2, 0], [3, 3, 0]]),
                                   [[0, 1, 2], [3, 4, 5]])
    meshes["sliver_faces"] = ok(np.array([[0, 0, 0], [1, 0, 0], [0.5, 1e-7, 0], [0.5, -1e-7, 0]]),
                                [[0, 1, 2], [1, 0, 3]])
    dup_pos, dup_polys = [], []
    for poly in g_polys:  # every face with its own copies of its corners (coincident vertices)
        dup_polys.append(list(range(len(dup_pos), len(dup_pos) + len(poly))))
        dup_pos += [g_pos[i] for i in poly]
    meshes["duplicate_vertices"] = ok(np.array(dup_pos), dup_polys)
    fan = [[0, 1, 2 + i] for i in range(8)]  # 8 faces on edge (0, 1): non-manifold
    fan_pos = [[0, 0, 0], [1, 0, 0]] + [[0.5, np.cos(a), np.sin(a)] for a in np.linspace(0, 6, 8)]
    meshes["nonmanifold_fan"] = ok(np.array(fan_pos), fan)
    meshes["inconsistent_winding"] = ok(g_pos, [p[::-1] if i % 2 else p for i, p in enumerate(g_polys)])
    tri_pos, tri_polys = grid(2, 2, triangles=True)
    quad_pos, quad_polys = grid(2, 2, offset=(3, 0, 0))
    n_pos, n_polys = ngon((8, 1), 1.0, 20, len(tri_pos) + len(quad_pos))
    quad_polys = [[i + len(tri_pos) for i in p] for p in quad_polys]
    meshes["tris_quads_20gon"] = ok(np.concatenate([tri_pos, quad_pos, n_pos]), tri_polys + quad_polys + n_polys)
    meshes["coords_1e30"] = (mesh_arrays(g_pos * 1e30, g_polys), "either")
    meshes["coords_near_float_max"] = (mesh_arrays(g_pos * np.float32(8e37), g_polys), "either")
    for label, value in (("nan", np.nan), ("inf", np.inf), ("neg_inf", -np.inf)):
        bad = g_pos.copy()
        bad[7, 1] = value
        meshes["coords_" + label] = (mesh_arrays(bad, g_polys), "error")
    two = np.concatenate([g_pos, g_pos + np.float32([10, 0, 0])])
    meshes["two_components"] = ok(two, g_polys + [[i + len(g_pos) for i in p] for p in g_polys])
    meshes["corner_vertex_out_of_range"] = (mesh_arrays(g_pos, g_polys[:-1] + [[0, 1, len(g_pos)]]), "error")
    meshes["corner_vertex_negative"] = (mesh_arrays(g_pos, g_polys[:-1] + [[0, 1, -1]]), "error")
    meshes["repeated_vertex_in_face"] = (mesh_arrays(g_pos, g_polys[:-1] + [[0, 1, 1, 5]]), "either")
    for size in (0, 1, 2):
        meshes["face_of_size_%d" % size] = (mesh_arrays(g_pos, g_polys[:-1] + [list(range(size))]), "error")
    m = mesh_arrays(g_pos, g_polys)
    m["poly_sizes"] = m["poly_sizes"].copy()
    m["poly_sizes"][3] = -4
    meshes["negative_face_size"] = (m, "error")
    m = mesh_arrays(g_pos, g_polys)
    m["poly_starts"] = m["poly_starts"].copy()
    m["poly_starts"][-1] = len(m["corner_verts"]) - 2  # runs past the end of corner_verts
    meshes["face_past_corner_array"] = (m, "error")
    m = mesh_arrays(g_pos, g_polys)
    m["poly_starts"] = m["poly_starts"].copy()
    m["poly_starts"][2] = m["poly_starts"][1]  # two faces share corners, one corner unused
    meshes["overlapping_faces"] = (m, "error")
    m = mesh_arrays(g_pos, g_polys)
    m["poly_starts"] = np.full_like(m["poly_starts"], -2147483648)
    meshes["int_min_starts"] = (m, "error")
    m = mesh_arrays(g_pos, g_polys)
    m["poly_sizes"] = np.full_like(m["poly_sizes"], 2147483647)
    meshes["int_max_sizes"] = (m, "error")
    return meshes


def shape_mismatches():
    """Arrays with wrong shapes/dtypes: caught at the Python boundary."""
    g = mesh_arrays(*grid(2, 2))
    bad = {}
    bad["positions_2_columns"] = dict(g, positions=g["positions"][:, :2])
    bad["positions_1d"] = dict(g, positions=g["positions"].ravel())
    bad["sizes_length_mismatch"] = dict(g, poly_sizes=g["poly_sizes"][:-1])
    bad["corner_verts_float"] = dict(g, corner_verts=g["corner_verts"].astype(np.float64) + 0.5)
    bad["corner_verts_int64_overflow"] = dict(g, corner_verts=g["corner_verts"].astype(np.int64) + 2**40)
    bad["corner_verts_2d"] = dict(g, corner_verts=g["corner_verts"].reshape(-1, 1))
    return bad


# ---------------------------------------------------------------- corpus

def write(path, data):
    os.makedirs(os.path.dirname(path), exist_ok=True)
    with open(path, "wb") as f:
        f.write(data)


def image_cases(out):
    pixels = sample_pixels()
    files = {}
    d = os.path.join(out, "images")
    os.makedirs(d, exist_ok=True)

    def add(name, data, expect):
        write(os.path.join(d, name), data)
        files[name] = expect

    add("sample.png", png_from_array(pixels), "ok")
    add("zero_bytes.png", b"", "error")
    add("zero_bytes.exr", b"", "error")
    png = png_from_array(pixels)
    for fraction in (0.1, 0.5, 0.9):
        add("truncated_%d.png" % int(fraction * 100), png[:int(len(png) * fraction)], "error")
    add("1x1.png", png_from_array(pixels[:1, :1]), "either")  # loads; preprocessing refuses (smaller than n)
    add("16bit.png", png_from_array((pixels.astype(np.uint16) * 257)), "ok")
    add("two_channel.png", png_from_array(pixels[..., :2]), "ok")
    add("gray.png", png_from_array(pixels[..., :1]), "ok")
    palette = bytes((np.arange(256 * 3) % 256).astype(np.uint8))
    add("palette.png", png_bytes(SAMPLE_SIZE, SAMPLE_SIZE, 3, 8, [bytes(pixels[y, :, 0]) for y in range(SAMPLE_SIZE)],
                                 palette=palette), "ok")
    add("bad_crc.png", png[:40] + bytes([png[40] ^ 0xFF]) + png[41:], "either")
    huge = png_bytes(16384, 16384, 0, 8, lambda y: bytes(16384))  # 256 MPixel of zeros, ~270 KB compressed
    add("huge_16k.png", huge, "error")
    claimed = bytearray(png)  # header claims 16k x 16k, data is 32 x 32
    claimed[16:24] = struct.pack(">II", 16384, 16384)
    claimed[29:33] = struct.pack(">I", zlib.crc32(bytes(claimed[12:29])) & 0xFFFFFFFF)
    add("huge_header_only.png", bytes(claimed), "error")
    nan = pixels.astype(np.float32) / 255
    nan[3, 4, 1] = np.nan
    add("nan_pixel.pfm", pfm_bytes(nan), "error")
    inf = pixels.astype(np.float32) / 255
    inf[5, 5, 0] = np.inf
    add("inf_pixel.pfm", pfm_bytes(inf), "error")
    add("not_an_image.png", b"hello, I am text pretending to be a PNG\n" * 4, "error")
    # fuzz_image's reproducer: made OpenImageIO's GIF reader call std::terminate (now refused unread).
    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    gif = open(os.path.join(root, "cpp_tests", "fuzz", "regressions", "fuzz_image", "gif_reader_terminate"), "rb").read()[1:]
    add("damaged.gif", gif, "error")
    add("damaged_gif_named.png", gif, "error")
    add("photoshop.psd", b"8BPS\x00\x01" + bytes(64), "error")
    # oiiotool-made formats (JPEG, EXR, CMYK TIFF, NaN EXR) and truncations of them.
    src = os.path.join(d, "sample.png")
    for name, args in (("sample.jpg", []), ("sample.exr", ["-d", "half"]), ("sample.tif", [])):
        oiiotool(src, *args, "-o", os.path.join(d, name))
        files[name] = "ok"
    oiiotool("--pattern", "checker", "%dx%d" % (SAMPLE_SIZE, SAMPLE_SIZE), "4", "--attrib", "tiff:ColorSpace", "CMYK",
             "-d", "uint8", "-o", os.path.join(d, "cmyk.tif"))
    files["cmyk.tif"] = "either"
    oiiotool("--pattern", "constant:color=nan,inf,1", "8x8", "3", "-d", "float", "-o", os.path.join(d, "nan_inf.exr"))
    files["nan_inf.exr"] = "error"
    for name in ("sample.jpg", "sample.exr", "sample.tif"):
        data = open(os.path.join(d, name), "rb").read()
        stem, ext = os.path.splitext(name)
        add("truncated_%s%s" % (stem.replace("sample", "half"), ext), data[:len(data) // 2], "error")
        add("truncated_header%s" % ext, data[:20], "error")
    os.makedirs(os.path.join(d, "directory.png"), exist_ok=True)
    files["directory.png"] = "error"
    files["missing.png"] = "error"
    return [dict(id="image/" + name, kind="image", file="images/" + name, expect=expect)
            for name, expect in sorted(files.items())]


def array_cases():
    """Images passed as numpy arrays (the add-on's path for images inside the .blend)."""
    specs = {
        "empty": ("zeros", [0, 0, 3], "float32", "error"),
        "1x1": ("zeros", [1, 1, 3], "float32", "error"),
        "nan": ("nan", [16, 16, 3], "float32", "error"),
        "inf": ("inf", [16, 16, 3], "float32", "error"),
        "five_channels": ("ramp", [16, 16, 5], "float32", "error"),
        "two_channels": ("ramp", [16, 16, 2], "float32", "ok"),
        "gray_2d": ("ramp", [16, 16], "float32", "ok"),
        "four_dims": ("ramp", [2, 16, 16, 3], "float32", "error"),
        "int64": ("ramp", [16, 16, 3], "int64", "error"),
        "bool": ("ramp", [16, 16, 3], "bool", "error"),
        "object": ("ramp", [16, 16, 3], "object", "error"),
        "uint16": ("ramp", [16, 16, 3], "uint16", "ok"),
        "float64": ("ramp", [16, 16, 3], "float64", "error"),
        "non_contiguous": ("strided", [16, 16, 3], "float32", "ok"),
        "huge_16k_broadcast": ("broadcast", [16384, 16384, 1], "uint8", "error"),
    }
    return [dict(id="array/" + name, kind="array", fill=fill, shape=shape, dtype=dtype, expect=expect)
            for name, (fill, shape, dtype, expect) in specs.items()]


def preprocess_cases(pixels_count=SAMPLE_SIZE * SAMPLE_SIZE):
    base = dict(SMALL_PARAMS)
    variations = {
        "neighbourhood_0": dict(neighbourhood=0), "neighbourhood_1": dict(neighbourhood=1),
        "neighbourhood_negative": dict(neighbourhood=-3), "neighbourhood_even_2": dict(neighbourhood=2),
        "neighbourhood_even_4": dict(neighbourhood=4), "neighbourhood_even_10": dict(neighbourhood=10),
        "neighbourhood_larger_than_image": dict(neighbourhood=33), "neighbourhood_huge": dict(neighbourhood=2**31 - 1),
        "textons_negative": dict(num_textons=-1), "textons_more_than_pixels": dict(num_textons=pixels_count + 1),
        "textons_equal_pixels": dict(num_textons=pixels_count, feature_dims=2),
        "textons_huge": dict(num_textons=2**31 - 1),
        "jump_candidates_0": dict(jump_candidates=0), "jump_candidates_negative": dict(jump_candidates=-5),
        "jump_candidates_huge": dict(jump_candidates=10**6), "feature_dims_negative": dict(feature_dims=-1),
        "feature_dims_huge": dict(feature_dims=10**6), "feature_dims_full": dict(feature_dims=0),
        "seed_zero": dict(seed=0), "seed_max": dict(seed=2**64 - 1), "seed_negative": dict(seed=-1),
        "seed_too_big": dict(seed=2**64), "tileable": dict(tileable=True),
        "color_space_bogus": dict(color_space="bogus"), "color_space_linear": dict(color_space="linear"),
        "neighbourhood_float": dict(neighbourhood=3.5), "textons_string": dict(num_textons="many"),
    }
    expect = {"textons_equal_pixels": "ok", "feature_dims_full": "ok", "seed_zero": "ok", "seed_max": "ok",
              "tileable": "ok", "color_space_linear": "ok"}
    return [dict(id="preprocess/" + name, kind="preprocess", file="images/sample.png", params=dict(base, **change),
                 expect=expect.get(name, "error")) for name, change in variations.items()]


def synth_cases():
    nan, inf = float("nan"), float("inf")
    variations = {
        "scale_zero": dict(scale=0.0), "scale_negative": dict(scale=-2.0), "scale_huge": dict(scale=1e30),
        "scale_tiny": dict(scale=1e-30), "scale_nan": dict(scale=nan), "scale_inf": dict(scale=inf),
        "scale_huge_allow_oversized": dict(scale=1e30, allow_oversized=True),
        "jump_rate_zero": dict(jump_rate=0.0), "jump_rate_negative": dict(jump_rate=-1.0),
        "jump_rate_tiny": dict(jump_rate=1e-12), "jump_rate_huge": dict(jump_rate=1e30),
        "jump_rate_nan": dict(jump_rate=nan), "jump_rate_inf": dict(jump_rate=inf),
        "seed_max": dict(seed=2**64 - 1), "seed_negative": dict(seed=-1), "seed_too_big": dict(seed=2**64),
        "no_blend": dict(blend=False), "orientation_bogus": dict(orientation="sideways"),
        "axis_zero": dict(axis=[0, 0, 0]), "axis_nan": dict(axis=[nan, 0, 1]), "axis_2_values": dict(axis=[0, 1]),
        "axis_along_normal": dict(axis=[0, 0, 1]),
        "anchors_out_of_range": dict(orientation="anchors", anchor_vertices=[999], anchor_directions=[[1, 0, 0]]),
        "anchors_negative": dict(orientation="anchors", anchor_vertices=[-1], anchor_directions=[[1, 0, 0]]),
        "anchors_none": dict(orientation="anchors"),
        "anchors_parallel_to_normal": dict(orientation="anchors", anchor_vertices=[0], anchor_directions=[[0, 0, 1]]),
        "anchors_nan": dict(orientation="anchors", anchor_vertices=[0], anchor_directions=[[nan, 0, 0]]),
        "anchors_length_mismatch": dict(orientation="anchors", anchor_vertices=[0, 1], anchor_directions=[[1, 0, 0]]),
        "sources_and_sinks": dict(orientation="anchors", sources=[0], sinks=[24]),
        "source_equals_sink": dict(orientation="anchors", sources=[3], sinks=[3]),
        "field_without_direction": dict(orientation="field"),
        "field_wrong_shape": dict(orientation="field", direction="wrong_shape"),
        "field_all_zero": dict(orientation="field", direction="zeros"),
        "field_nan": dict(orientation="field", direction="nan"),
        "scale_multiplier_zero": dict(scale_multiplier="zeros"),
        "scale_multiplier_nan": dict(scale_multiplier="nan"),
        "scale_multiplier_wrong_shape": dict(scale_multiplier="wrong_shape"),
        "normals_nan": dict(normals="nan"), "normals_zero": dict(normals="zeros"),
    }
    ok = {"seed_max", "no_blend", "axis_along_normal", "sources_and_sinks", "field_all_zero", "normals_zero",
          "jump_rate_tiny", "scale_tiny"}
    either = {"source_equals_sink"}
    cases = []
    for name, change in variations.items():
        expect = "ok" if name in ok else "either" if name in either else "error"
        cases.append(dict(id="synth/" + name, kind="synth", mesh="meshes/grid_quads.npz",
                          params=dict(dict(scale=4.0), **change), expect=expect))
    cases.append(dict(id="synth/components_anchor_on_one", kind="synth", mesh="meshes/two_components.npz",
                      params=dict(scale=4.0, orientation="anchors", anchor_vertices=[0], anchor_directions=[[1, 0, 0]]),
                      expect="ok"))
    cases.append(dict(id="synth/components_no_anchor", kind="synth", mesh="meshes/two_components.npz",
                      params=dict(scale=4.0), expect="ok"))
    return cases


def mesh_cases(out):
    cases = []
    d = os.path.join(out, "meshes")
    os.makedirs(d, exist_ok=True)
    for name, (arrays, expect) in hostile_meshes().items():
        np.savez(os.path.join(d, name + ".npz"), **arrays)
        for scale in (4.0, 1e-3):  # 1e-3: every face is far below a texel
            cases.append(dict(id="mesh/%s@scale=%g" % (name, scale), kind="mesh", mesh="meshes/%s.npz" % name,
                              params=dict(scale=scale), expect=expect))
        # The texton method (Magda & Kriegman) on the same meshes.
        cases.append(dict(id="texton/%s" % name, kind="texton", mesh="meshes/%s.npz" % name,
                          params=dict(scale=4.0), expect=expect))
    for name, arrays in shape_mismatches().items():
        np.savez(os.path.join(d, name + ".npz"), **arrays)
        cases.append(dict(id="mesh/" + name, kind="mesh", mesh="meshes/%s.npz" % name, params=dict(scale=4.0),
                          expect="error"))
    if os.environ.get("TEXSYNTH_HOSTILE_HUGE") == "1":
        cases.append(dict(id="mesh/huge_10M_faces", kind="huge_mesh", faces=HUGE_FACES, params=dict(scale=0.05),
                          expect="ok", timeout=1800))
    return cases


# Byte ranges of the cache layout (cache.hpp), for mutations per field.
CACHE_FIELDS = [("magic", 0, 8), ("version", 8, 12), ("params", 12, 56), ("sample_hash", 56, 64),
                ("dims", 64, 96)]
MUTATIONS = {"xor01": lambda b: b ^ 0x01, "xor80": lambda b: b ^ 0x80, "zero": lambda b: 0x00,
             "ff": lambda b: 0xFF, "inc": lambda b: (b + 1) & 0xFF}


def cache_cases(out, native):
    """A valid cache, then every single-byte mutation class on every header byte and on sampled
    payload bytes of each section, truncations at random lengths, an extra byte, and hash mismatch."""
    d = os.path.join(out, "caches")
    os.makedirs(d, exist_ok=True)
    pre = native.preprocess(os.path.join(out, "images", "sample.png"), **SMALL_PARAMS)
    valid_path = os.path.join(d, "valid.tscache")
    pre.save(valid_path)
    valid = open(valid_path, "rb").read()
    n = pre.width * pre.height
    k, dims, jk = pre.num_textons, pre.texton_dims, pre.params["jump_candidates"]
    header = 96
    sections = [("texton_map", header, header + 2 * n)]
    sections.append(("textons", sections[-1][2], sections[-1][2] + 4 * k * dims))
    sections.append(("jump_targets", sections[-1][2], sections[-1][2] + 4 * n * jk))
    sections.append(("jump_weights", sections[-1][2], sections[-1][2] + 2 * n * jk))
    sections.append(("checksum", len(valid) - 8, len(valid)))
    assert sections[-2][2] == len(valid) - 8, "cache layout changed: update CACHE_FIELDS"
    rng = random.Random(1234)
    cases = [dict(id="cache/valid", kind="cache", file="caches/valid.tscache", expect="ok")]
    offsets = [(name, o) for name, a, b in CACHE_FIELDS for o in range(a, b)]
    for name, a, b in sections:
        picks = sorted(set([a, b - 1] + [rng.randrange(a, b) for _ in range(6)]))
        offsets += [(name, o) for o in picks]
    mutated = 0
    for name, offset in offsets:
        for label, mutate in MUTATIONS.items():
            new = mutate(valid[offset])
            if new == valid[offset]:
                continue
            data = bytearray(valid)
            data[offset] = new
            file = "caches/%s_%d_%s.tscache" % (name, offset, label)
            write(os.path.join(out, file), bytes(data))
            cases.append(dict(id="cache/%s@%d/%s" % (name, offset, label), kind="cache", file=file, expect="error"))
            mutated += 1
    lengths = sorted(set([0, 1, 7, 8, 95, 96, 97, len(valid) - 9, len(valid) - 1] +
                         [rng.randrange(1, len(valid)) for _ in range(40)]))
    for length in lengths:
        file = "caches/truncated_%d.tscache" % length
        write(os.path.join(out, file), valid[:length])
        cases.append(dict(id="cache/truncated@%d" % length, kind="cache", file=file, expect="error"))
    write(os.path.join(out, "caches/extra_byte.tscache"), valid + b"\0")
    cases.append(dict(id="cache/extra_byte", kind="cache", file="caches/extra_byte.tscache", expect="error"))
    wrong_version = bytearray(valid)
    wrong_version[8:12] = struct.pack("<I", 1)
    write(os.path.join(out, "caches/version_1.tscache"), bytes(wrong_version))
    cases.append(dict(id="cache/version_mismatch", kind="cache", file="caches/version_1.tscache", expect="error"))
    cases.append(dict(id="cache/hash_mismatch", kind="cache", file="caches/valid.tscache",
                      expected_hash=(pre.sample_hash + 1) % 2**64, expect="error"))
    os.makedirs(os.path.join(d, "directory.tscache"), exist_ok=True)
    cases.append(dict(id="cache/directory", kind="cache", file="caches/directory.tscache", expect="error"))
    # A corrupt file at the very path preprocess(cache_dir=...) uses: must be recomputed and replaced.
    for label in ("truncated_96", "checksum_%d_xor01" % (len(valid) - 8), "textons_%d_ff" % sections[1][1]):
        source = "caches/%s.tscache" % label
        if os.path.exists(os.path.join(out, source)):
            cases.append(dict(id="cache/recompute_over_%s" % label, kind="cache_dir", file=source,
                              image="images/sample.png", params=SMALL_PARAMS, expect="ok"))
    return cases


def generate(out, native):
    os.makedirs(out, exist_ok=True)
    cases = image_cases(out) + array_cases() + preprocess_cases()
    cases += mesh_cases(out) + synth_cases() + cache_cases(out, native)
    ids = [c["id"] for c in cases]
    assert len(ids) == len(set(ids)), "duplicate case ids"
    with open(os.path.join(out, "cases.json"), "w") as f:
        json.dump(cases, f, indent=1)
    return cases


if __name__ == "__main__":
    sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))),
                                    "addon"))
    import texsynth_native
    if len(sys.argv) != 2:
        sys.exit("usage: make_corpus.py OUT_DIR")
    print("%d cases written to %s" % (len(generate(sys.argv[1], texsynth_native)), sys.argv[1]))
