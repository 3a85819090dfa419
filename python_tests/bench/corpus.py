# SPDX-License-Identifier: GPL-3.0-or-later
"""The unseen corpus (issue 29): 30 texture samples and 4 meshes that none of TexSynth's defaults were tuned on,
made deterministically in out/corpus/ from Debian packages (downloaded with `apt-get download`, unpacked with
dpkg-deb, never installed) and a few procedural generators with fixed seeds. Documented in docs/benchmarks/corpus.md.

  /usr/bin/python3.11 python_tests/bench/corpus.py [--out out/corpus] [--only NAME,...] [--list]

Writes out/corpus/samples/<name>.png (8-bit RGB, or 8-bit grey for grey samples), out/corpus/meshes/<name>.obj
(Y-up OBJ, longest side 1 unit, centred: Blender's importer turns it Z-up) and out/corpus/manifest.json:
{"samples": [{name, category, width, height, colour ("colour"|"grey"), tileable, source, licence, file, sha256}],
 "meshes": [{name, kind, vertices, triangles, genus, source, licence, file}]}. Images are read with
texsynth_native.load_image (OpenImageIO: PNG, JPEG, WebP) from addon/; GIMP .pat patterns are decoded here.
Running it again reuses the downloaded packages (out/corpus/debs) and rewrites identical files; a sample whose
SHA-256 differs from the one recorded below (a new package version) is reported, not refused.
"""
import argparse
import hashlib
import json
import math
import os
import shutil
import struct
import subprocess
import sys
import tempfile
import zlib

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, os.environ.get("TEXSYNTH_MODULE_DIR", os.path.join(ROOT, "addon")))

# Debian 12 packages: name -> licence of the files taken (from the package's debian/copyright).
PACKAGES = {
    "gimp-data": "GPL-3+ (gimp-data debian/copyright, 'Files: *': the patterns have no stanza of their own)",
    "extremetuxracer-data": "GPL-2+ (extremetuxracer-data debian/copyright, 'Files: *')",
    "mate-backgrounds": "GPL-2+ (mate-backgrounds debian/copyright, per-file stanza)",
    "plasma-workspace-wallpapers": "GPL-2+ (plasma-workspace-wallpapers debian/copyright, 'Files: *')",
    "gnome-backgrounds": "GPL-2+ (gnome-backgrounds debian/copyright: package licence; the 43.x wallpapers "
                         "have no per-file entry)",
    "blender-data": "GPL-2+ (Blender's bundled add-on Archimesh, blender-data debian/copyright, 'Files: *')",
    "libcgal-demo": "CC0-1.0 (CGAL data files without a copyright notice, libcgal-dev debian/copyright)",
}

GIMP = "usr/share/gimp/2.0/patterns/"
ETR = "usr/share/games/etr/terrains/"
MATE = "usr/share/backgrounds/mate/nature/"
PLASMA = "usr/share/wallpapers/"
GNOME = "usr/share/backgrounds/gnome/"
CGAL_DATA = "usr/share/doc/libcgal-dev/data.tar.gz"

# name, category, (package, member) or ("generated", function), crop (x, y, w, h) or None, grey?, tileable
# category: regular | near-regular | stochastic | element
SAMPLES = [
    # regular: bricks, tiles, weaves
    ("burlap_weave", "regular", ("gimp-data", GIMP + "Fabric/burlap.pat"), None, False, True),
    ("parquet_basket", "regular", ("gimp-data", GIMP + "Wood/parque3.pat"), None, False, True),
    ("brick_small", "regular", ("gimp-data", GIMP + "Stone/brick.pat"), None, False, True),
    ("marble_tiles_grey", "regular", ("gimp-data", GIMP + "Stone/marble2.pat"), None, True, True),
    ("paving_bricks", "regular", ("extremetuxracer-data", ETR + "pave02.png"), None, False, True),
    ("slate_paving", "regular", ("extremetuxracer-data", ETR + "pave01.png"), None, False, True),
    ("fabric_weave_grey", "regular", ("blender-data",
                                      "usr/share/blender/scripts/addons/archimesh/images/fabric_diffuse.png"),
     None, True, True),
    ("square_tiles_grey", "regular", ("generated", "square_tiles"), None, True, True),
    ("truchet_2048", "regular", ("gnome-backgrounds", GNOME + "truchet-l.webp"), (1024, 1024, 2048, 2048),
     False, False),
    # near-regular
    ("flagstones", "near-regular", ("gimp-data", GIMP + "Stone/stone33.pat"), None, False, True),
    ("stone_wall", "near-regular", ("gimp-data", GIMP + "Stone/rock.pat"), None, False, True),
    ("dried_mud", "near-regular", ("gimp-data", GIMP + "Stone/cracked.pat"), None, False, True),
    ("leaf_veins_1024", "near-regular", ("mate-backgrounds", MATE + "Blinds.jpg"), (600, 100, 1024, 1024),
     False, False),
    ("woven_facade_grey_1536", "near-regular", ("plasma-workspace-wallpapers",
                                                PLASMA + "Grey/contents/images/2560x1600.jpg"),
     (0, 32, 1536, 1536), True, False),
    ("wood_grain_2048", "near-regular", ("gnome-backgrounds", GNOME + "wood-l.webp"), (1024, 1024, 2048, 2048),
     False, False),
    ("cracked_rock", "near-regular", ("extremetuxracer-data", ETR + "rock06.png"), None, False, True),
    # stochastic: gravel, grass, sand
    ("gravel", "stochastic", ("extremetuxracer-data", ETR + "floor01.png"), None, False, True),
    ("grass", "stochastic", ("extremetuxracer-data", ETR + "grass02.png"), None, False, True),
    ("sand", "stochastic", ("extremetuxracer-data", ETR + "sand01.png"), None, False, True),
    ("dirt_grey", "stochastic", ("extremetuxracer-data", ETR + "dirt01.png"), None, True, True),
    ("granite_grey", "stochastic", ("gimp-data", GIMP + "Stone/granite1.pat"), None, True, True),
    ("moon_dust_grey", "stochastic", ("gimp-data", GIMP + "Stone/Moonfoot.pat"), None, True, True),
    ("meadow_1024", "stochastic", ("mate-backgrounds", MATE + "GreenMeadow.jpg"), (128, 0, 1024, 1024),
     False, False),
    # element-like: leaves, pebbles, scales
    ("cobbles", "element", ("extremetuxracer-data", ETR + "pebbles01.png"), None, False, True),
    ("pebble_mix", "element", ("extremetuxracer-data", ETR + "pebbles04.png"), None, False, True),
    ("leopard_spots", "element", ("gimp-data", GIMP + "Animal/leopard.pat"), None, False, True),
    ("coffee_beans", "element", ("gimp-data", GIMP + "Food/java.pat"), None, False, True),
    ("cups_1536", "element", ("plasma-workspace-wallpapers", PLASMA + "ColorfulCups/contents/images/2560x1600.jpg"),
     (1024, 64, 1536, 1536), False, False),
    ("fish_scales", "element", ("generated", "fish_scales"), None, False, True),
    ("fallen_leaves", "element", ("generated", "fallen_leaves"), None, False, True),
]

# name, kind, source: ("libcgal-demo", data/meshes/<file>.off)
MESHES = [
    ("bunny", "scanned organic (Stanford bunny, holes closed)", "bunny00.off",
     "Stanford 3D Scanning Repository (Turk & Levoy 1994), redistributable with acknowledgement; "
     "as shipped in CGAL's data (libcgal-demo)"),
    ("part", "CAD-like: sharp edges, long thin triangles (median longest-edge/height 7, 99th percentile 37)",
     "part.off", PACKAGES["libcgal-demo"]),
    ("elk", "thin parts: antlers, legs and ears", "elk.off", PACKAGES["libcgal-demo"]),
    ("anchor", "genus 4, very uneven triangles (areas span 3.4e4x, longest-edge/height up to 160)", "anchor.off",
     PACKAGES["libcgal-demo"]),
]

# SHA-256 of the written sample files with Debian 12's package versions (gimp-data 2.10.34-1+deb12u10,
# extremetuxracer-data 0.8.2-1, mate-backgrounds 1.26.0-1, plasma-workspace-wallpapers 4:5.27.5-2,
# gnome-backgrounds 43.1-1, blender-data 3.4.1+dfsg-2, libcgal-demo 5.5.1-2): written by --record, compared
# on every run.
EXPECTED_SHA256_FILE = os.path.join(HERE, "corpus_sha256.json")


# ----------------------------------------------------------------------------------------------- files

def write_png(path, pixels):
    """(H, W) or (H, W, 3) floats in [0, 1], row 0 = top, as an 8-bit grey or RGB PNG."""
    a = np.clip(np.asarray(pixels, np.float64) * 255.0 + 0.5, 0, 255).astype(np.uint8)
    if a.ndim == 3 and a.shape[2] == 1:
        a = a[..., 0]
    height, width = a.shape[:2]
    colour_type = 0 if a.ndim == 2 else 2
    raw = b"".join(b"\0" + a[y].tobytes() for y in range(height))

    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)
    with open(path, "wb") as handle:
        handle.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, colour_type,
                                                                      0, 0, 0))
                     + chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b""))


def read_pat(path):
    """GIMP pattern: big-endian header (header size, version, width, height, bytes per pixel, 'GPAT', name),
    then rows top first. Returns (H, W, C) floats."""
    with open(path, "rb") as handle:
        data = handle.read()
    header, _version, width, height, depth = struct.unpack(">5I", data[:20])
    if data[20:24] != b"GPAT":
        raise ValueError("%s is not a GIMP pattern" % path)
    pixels = np.frombuffer(data[header:header + width * height * depth], np.uint8).reshape(height, width, depth)
    return pixels.astype(np.float64) / 255.0


def read_image(path):
    if path.endswith(".pat"):
        return read_pat(path)
    import texsynth_native
    return np.asarray(texsynth_native.load_image(path), np.float64)


def to_grey(rgb):
    if rgb.ndim == 2:
        return rgb
    if rgb.shape[2] < 3:
        return rgb[..., 0]
    return rgb[..., 0] * 0.2126 + rgb[..., 1] * 0.7152 + rgb[..., 2] * 0.0722


def sha256(path):
    with open(path, "rb") as handle:
        return hashlib.sha256(handle.read()).hexdigest()


class Packages:
    """Debian packages downloaded once into `folder` and unpacked next to them (never installed)."""

    def __init__(self, folder):
        self.folder = folder
        os.makedirs(folder, exist_ok=True)
        self.versions = {}

    def deb(self, name):
        found = [f for f in os.listdir(self.folder) if f.startswith(name + "_") and f.endswith(".deb")]
        if not found:
            os.chmod(self.folder, 0o777)  # apt's _apt user writes into it
            command = ["apt-get", "download", "-q", name]
            if os.geteuid() != 0:
                command.insert(0, "sudo")
            result = subprocess.run(command, cwd=self.folder, capture_output=True, text=True)
            if result.returncode != 0:
                subprocess.run((["sudo"] if os.geteuid() != 0 else []) + ["apt-get", "update", "-q"], check=True)
                subprocess.run(command, cwd=self.folder, check=True)
            found = [f for f in os.listdir(self.folder) if f.startswith(name + "_") and f.endswith(".deb")]
        found.sort()
        self.versions[name] = found[-1].split("_")[1].replace("%3a", ":")
        return os.path.join(self.folder, found[-1])

    def member(self, name, member):
        """Path of one file of the package, unpacked into folder/x/<name>/."""
        target = os.path.join(self.folder, "x", name, member)
        if not os.path.isfile(target):
            if name == "blender-data" and os.path.isfile("/" + member):  # Debian's Blender is installed
                query = subprocess.run(["dpkg-query", "-W", "-f", "${Version}", name], capture_output=True, text=True)
                self.versions[name] = (query.stdout.strip() or "?") + " (installed)"
                return "/" + member
            deb = self.deb(name)
            os.makedirs(os.path.join(self.folder, "x", name), exist_ok=True)
            tar = subprocess.Popen(["dpkg-deb", "--fsys-tarfile", deb], stdout=subprocess.PIPE)
            subprocess.run(["tar", "-x", "-C", os.path.join(self.folder, "x", name), "./" + member],
                           stdin=tar.stdout, check=True)
            tar.wait()
        elif name not in self.versions and name != "blender-data":
            self.deb(name)
        return target


# ----------------------------------------------------------------------------------------- generators

def _smooth_noise(shape, cell, rng):
    """Tileable value noise: a random lattice of period shape/cell, bicubic-smoothed."""
    h, w = shape
    gh, gw = max(1, h // cell), max(1, w // cell)
    grid = rng.random((gh, gw))
    y = np.arange(h) * gh / h
    x = np.arange(w) * gw / w
    y0, x0 = np.floor(y).astype(int), np.floor(x).astype(int)
    fy, fx = y - y0, x - x0
    fy, fx = fy * fy * (3 - 2 * fy), fx * fx * (3 - 2 * fx)
    a = grid[y0 % gh][:, x0 % gw]
    b = grid[y0 % gh][:, (x0 + 1) % gw]
    c = grid[(y0 + 1) % gh][:, x0 % gw]
    d = grid[(y0 + 1) % gh][:, (x0 + 1) % gw]
    top = a + (b - a) * fx[None, :]
    bottom = c + (d - c) * fx[None, :]
    return top + (bottom - top) * fy[:, None]


def _fractal(shape, rng, cells=(32, 16, 8, 4)):
    total = sum(_smooth_noise(shape, c, rng) / (i + 1) for i, c in enumerate(cells))
    total -= total.min()
    return total / max(total.max(), 1e-9)


def square_tiles(rng):
    """160 x 160 grey floor tiles: 4 x 4 tiles of 40 px, 3 px grout, per-tile tone and a fine speckle."""
    size, tile, grout = 160, 40, 3
    y, x = np.mgrid[0:size, 0:size]
    tone = 0.55 + 0.18 * rng.random((size // tile, size // tile))
    image = tone[y // tile, x // tile] + 0.06 * (_fractal((size, size), rng, (20, 10, 5)) - 0.5)
    image += 0.03 * rng.standard_normal((size, size))
    in_grout = ((y % tile) < grout) | ((x % tile) < grout)
    image[in_grout] = 0.25 + 0.03 * rng.standard_normal(in_grout.sum())
    bevel = ((y % tile) == grout) | ((x % tile) == grout)
    image[bevel & ~in_grout] *= 0.8
    return np.clip(image, 0, 1)


def fish_scales(rng):
    """128 x 128 tileable overlapping scales: rows of discs (period 32 x 16, every other row offset by half),
    each lower row drawn over the one above, dark rim, per-scale hue, a highlight towards the top."""
    size, period_x, period_y, radius = 128, 32, 16, 19.0
    image = np.zeros((size, size, 3))
    y, x = np.mgrid[0:size, 0:size].astype(np.float64)
    for row in range(-2, size // period_y + 2):
        for col in range(-1, size // period_x + 2):
            cx = col * period_x + (period_x / 2 if row % 2 else 0.0)
            cy = row * period_y
            for oy in (-size, 0, size):
                for ox in (-size, 0, size):
                    d = np.hypot(x - cx - ox, y - cy - oy)
                    inside = (d < radius) & (y >= cy + oy - 2)
                    if not inside.any():
                        continue
                    base = np.array([0.25, 0.45 + 0.15 * rng.random(), 0.45 + 0.2 * rng.random()])
                    shade = 0.65 + 0.45 * np.clip((y - cy - oy) / radius, 0, 1)
                    colour = base[None, None, :] * shade[..., None]
                    rim = (d > radius - 2.5)[..., None]
                    colour = np.where(rim, colour * 0.35, colour)
                    image[inside] = colour[inside]
    return np.clip(image, 0, 1)


def fallen_leaves(rng):
    """384 x 384 tileable fallen leaves (element-like): 70 pointed leaves (a midrib, two veins per side, an
    orange-to-brown colour each) at random positions and angles over dark soil, later ones on top."""
    size = 384
    soil = 0.16 + 0.12 * _fractal((size, size), rng, (48, 24, 12, 6))
    image = np.stack([soil * 1.1, soil * 0.85, soil * 0.6], -1)
    y, x = np.mgrid[0:size, 0:size].astype(np.float64)
    for _ in range(70):
        cx, cy = rng.random(2) * size
        angle = rng.random() * math.pi
        length, width = 26 + 14 * rng.random(), 10 + 5 * rng.random()
        hue = rng.random()
        colour = np.array([0.75 + 0.2 * hue, 0.35 + 0.3 * (1 - hue), 0.08 + 0.1 * rng.random()]) * (0.7 + 0.3 * rng.random())
        for oy in (-size, 0, size):
            for ox in (-size, 0, size):
                dx, dy = x - cx - ox, y - cy - oy
                u = (dx * math.cos(angle) + dy * math.sin(angle)) / length  # along the leaf, -1..1
                v = (-dx * math.sin(angle) + dy * math.cos(angle)) / width
                inside = (np.abs(u) < 1) & (np.abs(v) < (1 - u * u) * (1 - 0.3 * u))
                if not inside.any():
                    continue
                leaf = np.broadcast_to(colour, image.shape).copy()
                vein = (np.abs(v) < 0.06) | (np.abs(np.abs(v) - 0.45 * (1 - np.abs(u)) + 0.0 * u) < 0.05) & (np.abs(u) < 0.8)
                leaf[vein] *= 0.55
                leaf *= (0.85 + 0.15 * (1 - np.abs(v)))[..., None]
                image[inside] = leaf[inside]
    return np.clip(image, 0, 1)


GENERATORS = {"square_tiles": square_tiles, "fish_scales": fish_scales, "fallen_leaves": fallen_leaves}
GENERATOR_SEEDS = {"square_tiles": 2901, "fish_scales": 2902, "fallen_leaves": 2903}


# ----------------------------------------------------------------------------------------------- meshes

def read_off(path):
    with open(path) as handle:
        words = []
        for line in handle:
            line = line.split("#")[0].strip()
            if line:
                words.append(line.split())
    first = words[0]
    if first[0] != "OFF":
        raise ValueError("%s: not an OFF file" % path)
    counts, start = (first[1:], 1) if len(first) > 1 else (words[1], 2)
    nv, nf = int(counts[0]), int(counts[1])
    positions = np.array([[float(v) for v in w[:3]] for w in words[start:start + nv]])
    triangles = []
    for w in words[start + nv:start + nv + nf]:
        n = int(w[0])
        ids = [int(v) for v in w[1:1 + n]]
        triangles += [(ids[0], ids[k], ids[k + 1]) for k in range(1, n - 1)]
    return positions, np.array(triangles, np.int64)


def mesh_genus(positions, triangles):
    edges = np.sort(np.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]], triangles[:, [2, 0]]]), axis=1)
    edge_count = len(np.unique(edges, axis=0))
    used = len(np.unique(triangles))
    chi = used - edge_count + len(triangles)
    return (2 - chi) / 2.0


def write_obj(path, positions, triangles):
    centre = (positions.max(0) + positions.min(0)) / 2
    scaled = (positions - centre) / np.ptp(positions, axis=0).max()
    with open(path, "w") as handle:
        handle.write("# TexSynth corpus mesh (python_tests/bench/corpus.py), longest side 1 unit, Y up\n")
        handle.write("".join("v %.6f %.6f %.6f\n" % tuple(p) for p in scaled))
        handle.write("".join("f %d %d %d\n" % tuple(t + 1) for t in triangles))


# --------------------------------------------------------------------------------------------------- main

def build_sample(entry, packages, out_dir):
    name, category, (package, member), crop, grey, tileable = entry
    if package == "generated":
        pixels = GENERATORS[member](np.random.default_rng(GENERATOR_SEEDS[member]))
        source = "generated: python_tests/bench/corpus.py %s() seed %d" % (member, GENERATOR_SEEDS[member])
        licence = "CC0-1.0 (made by this repository)"
    else:
        pixels = read_image(packages.member(package, member))
        version = packages.versions.get(package, "installed")
        source = "Debian 12 package %s %s: /%s" % (package, version, member)
        licence = PACKAGES[package]
    if crop is not None:
        x, y, w, h = crop
        pixels = pixels[y:y + h, x:x + w]
        source += " (crop %d x %d at %d, %d)" % (w, h, x, y)
    if pixels.ndim == 3 and pixels.shape[2] == 4:
        pixels = pixels[..., :3]
    if grey:
        pixels = to_grey(pixels)
    elif pixels.ndim == 2 or pixels.shape[2] == 1:
        raise ValueError("%s: a colour sample from a grey image" % name)
    path = os.path.join(out_dir, "samples", name + ".png")
    write_png(path, pixels)
    return dict(name=name, category=category, width=int(pixels.shape[1]), height=int(pixels.shape[0]),
                colour="grey" if grey else "colour", tileable=bool(tileable), source=source, licence=licence,
                file=os.path.relpath(path, out_dir), sha256=sha256(path))


def build_mesh(entry, packages, out_dir):
    name, kind, off_name, licence = entry
    path = os.path.join(out_dir, "meshes", name + ".obj")
    archive = packages.member("libcgal-demo", CGAL_DATA)
    work = tempfile.mkdtemp()
    try:
        subprocess.run(["tar", "-xzf", archive, "-C", work, "data/meshes/" + off_name], check=True)
        positions, triangles = read_off(os.path.join(work, "data", "meshes", off_name))
    finally:
        shutil.rmtree(work)
    write_obj(path, positions, triangles)
    return dict(name=name, kind=kind, vertices=int(len(positions)), triangles=int(len(triangles)),
                genus=mesh_genus(positions, triangles),
                source="Debian 12 package libcgal-demo %s: data/meshes/%s in /%s"
                       % (packages.versions.get("libcgal-demo", "?"), off_name, CGAL_DATA),
                licence=licence, file=os.path.relpath(path, out_dir))


def main():
    parser = argparse.ArgumentParser(prog="corpus")
    parser.add_argument("--out", default=os.path.join(ROOT, "out", "corpus"))
    parser.add_argument("--only", default="", help="comma-separated sample / mesh names (default: all)")
    parser.add_argument("--list", action="store_true", help="print the corpus and exit")
    parser.add_argument("--record", action="store_true", help="record the written samples' SHA-256 as expected")
    args = parser.parse_args()
    if args.list:
        for s in SAMPLES:
            print("%-24s %-13s %s%s" % (s[0], s[1], s[2][0], " grey" if s[4] else ""))
        for m in MESHES:
            print("%-24s mesh          %s" % (m[0], m[2]))
        return
    only = {n for n in args.only.split(",") if n}
    for sub in ("samples", "meshes", "debs"):
        os.makedirs(os.path.join(args.out, sub), exist_ok=True)
    packages = Packages(os.path.join(args.out, "debs"))
    manifest_path = os.path.join(args.out, "manifest.json")
    manifest = {"samples": [], "meshes": []}
    if only and os.path.isfile(manifest_path):
        with open(manifest_path) as handle:
            manifest = json.load(handle)
    expected = {}
    if os.path.isfile(EXPECTED_SHA256_FILE):
        with open(EXPECTED_SHA256_FILE) as handle:
            expected = json.load(handle)
    samples = {s["name"]: s for s in manifest["samples"]}
    for entry in SAMPLES:
        if only and entry[0] not in only:
            continue
        record = build_sample(entry, packages, args.out)
        samples[record["name"]] = record
        note = ""
        if entry[0] in expected and expected[entry[0]] != record["sha256"]:
            note = "  (differs from the recorded SHA-256: another package version?)"
        print("corpus: %-24s %-13s %5d x %-5d %-6s %s%s" % (record["name"], record["category"], record["width"],
                                                            record["height"], record["colour"],
                                                            "tileable" if record["tileable"] else "", note))
    meshes = {m["name"]: m for m in manifest["meshes"]}
    for entry in MESHES:
        if only and entry[0] not in only:
            continue
        record = build_mesh(entry, packages, args.out)
        meshes[record["name"]] = record
        print("corpus: mesh %-8s %6d vertices %6d triangles genus %g" % (record["name"], record["vertices"],
                                                                          record["triangles"], record["genus"]))
    order = [s[0] for s in SAMPLES]
    manifest = {"samples": sorted(samples.values(), key=lambda s: order.index(s["name"]) if s["name"] in order else 99),
                "meshes": [meshes[m[0]] for m in MESHES if m[0] in meshes]}
    with open(manifest_path, "w") as handle:
        json.dump(manifest, handle, indent=1)
    if args.record:
        with open(EXPECTED_SHA256_FILE, "w") as handle:
            json.dump({s["name"]: s["sha256"] for s in manifest["samples"]}, handle, indent=1, sort_keys=True)
    print("corpus: %d samples, %d meshes in %s" % (len(manifest["samples"]), len(manifest["meshes"]), args.out))


if __name__ == "__main__":
    main()
