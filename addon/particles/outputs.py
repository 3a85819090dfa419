# SPDX-License-Identifier: GPL-3.0-or-later
"""What texture particles make from a place_particles result, bpy-free: the sprite atlas, the arrays
decal_mesh needs (substituted sprites, rotated frames, layer offsets) and the instance points' frames."""
import numpy as np

from ..core.settings import SettingsError


ATLAS_MAX_SIDE = 4096
ATLAS_PADDING = 2            # transparent pixels around every sprite (no bleeding under mipmaps or Linear)
# Decals lie above the surface in one band per class, later classes higher (the class order); within a band,
# decals of one class that overlap climb half a unit per level, lower-numbered on top, as the bake composites
# them (decal_mesh's stack_step), so none z-fights. Unit: DECAL_OFFSET_FACTOR x the target's bbox diagonal.
DECAL_OFFSET_FACTOR = 1e-4
DECAL_CLASS_BAND = 3.0      # units per class band: class rank r starts 1 + 3r units up
DECAL_STACK_STEP = 0.5      # units per stacking level (half a unit: Eevee's depth buffer still tells them apart)
DECAL_STACK_LEVELS = 5      # the top level stays below the next band (5 x 0.5 < 3); packed pebbles need 4


class Atlas:
    """Sprites packed into one RGBA image: cells[i] = (x, y, w, h) pixel rectangle (bottom-left origin) of
    sprite ids[i]; `dropped` = sprites per class left out to stay within the size limit."""

    def __init__(self, width, height, ids, cells, dropped, classes):
        self.width, self.height = width, height
        self.ids = np.asarray(ids, np.int32)
        self.classes = np.asarray(classes, np.int32)
        self.cells = np.asarray(cells, np.int32).reshape(-1, 4)
        self.dropped = dropped
        self.index = {int(s): i for i, s in enumerate(self.ids)}

    def uv_rects(self, sprite_ids):
        """(n, 4) float32 (s0, t0, s1, t1) of each sprite's cell, in [0, 1] atlas coordinates."""
        rows = np.array([self.index[int(s)] for s in sprite_ids], np.int64)
        cells = self.cells[rows].astype(np.float64) if rows.size else np.zeros((0, 4))
        scale = np.array([self.width, self.height, self.width, self.height], np.float64)
        return np.ascontiguousarray(np.column_stack([cells[:, 0], cells[:, 1], cells[:, 0] + cells[:, 2],
                                                     cells[:, 1] + cells[:, 3]]) / scale, dtype=np.float32)


def _shelf_pack(sizes, side, padding):
    """Positions (n, 2) of (w, h) boxes on shelves in a side x side square (tallest first), or None."""
    order = np.lexsort((-sizes[:, 0], -sizes[:, 1]))
    positions = np.zeros((sizes.shape[0], 2), np.int32)
    x = y = shelf = 0
    for i in order:
        w, h = int(sizes[i, 0]) + 2 * padding, int(sizes[i, 1]) + 2 * padding
        if w > side:
            return None
        if x + w > side:
            x, y, shelf = 0, y + shelf, 0
        if y + h > side:
            return None
        positions[i] = (x + padding, y + padding)
        x += w
        shelf = max(shelf, h)
    return positions


def pack_atlas(sprite_ids, sizes, classes, seed=0, max_side=ATLAS_MAX_SIDE, padding=ATLAS_PADDING):
    """Packs sprites (sizes (n, 2) = (w, h)) into the smallest power-of-two square <= max_side that holds
    them; beyond it, a random subset per class (seeded; every class keeps at least one sprite)."""
    ids = np.asarray(sprite_ids, np.int32)
    sizes = np.asarray(sizes, np.int64).reshape(-1, 2)
    classes = np.asarray(classes, np.int32)
    if ids.size == 0:
        raise SettingsError("no sprite to put in the atlas")
    if np.any(sizes + 2 * padding > max_side):
        raise SettingsError("a particle is larger than the %d px atlas" % max_side)
    keep = np.ones(ids.size, bool)
    rng = np.random.default_rng(seed)
    priority = rng.random(ids.size)  # lower = dropped first
    while True:
        kept = np.flatnonzero(keep)
        area = float(np.prod(sizes[kept] + 2 * padding, axis=1).sum())
        side = 64
        while side < max_side and side * side < area:
            side *= 2
        while side <= max_side:
            positions = _shelf_pack(sizes[kept], side, padding)
            if positions is not None:
                cells = np.column_stack([positions, sizes[kept]])
                dropped = {}
                for c in np.unique(classes[~keep]):
                    dropped[int(c)] = int(np.count_nonzero(~keep & (classes == c)))
                return Atlas(side, side, ids[kept], cells, dropped, classes[kept])
            side *= 2
        # Drop a tenth of each class's remaining sprites (lowest priority first), keeping one per class.
        changed = False
        for c in np.unique(classes):
            members = np.flatnonzero(keep & (classes == c))
            drop = members.size // 10 if members.size > 10 else (1 if members.size > 1 else 0)
            if drop:
                keep[members[np.argsort(priority[members])[:drop]]] = False
                changed = True
        if not changed:
            raise SettingsError("the particles do not fit into a %d px atlas" % max_side)


def atlas_pixels(atlas, sprites):
    """(H, W, 4) float32 RGBA, row 0 = bottom: sprites[i] (h, w, 4, row 0 = bottom) in cell i; transparent
    elsewhere."""
    image = np.zeros((atlas.height, atlas.width, 4), np.float32)
    for (x, y, w, h), rgba in zip(atlas.cells, sprites):
        image[y:y + h, x:x + w] = rgba
    return image


def substitute_sprites(placed_sprites, placed_classes, atlas, angles_by_sprite):
    """Sprite per placed particle that is in the atlas: dropped sprites are replaced by a kept sprite of
    the same class (chosen by id). Returns (sprites, extra rotation in radians theta_s - theta_s' that keeps
    the particle's box direction)."""
    sprites = np.asarray(placed_sprites, np.int32).copy()
    turn = np.zeros(sprites.size, np.float64)
    if not atlas.dropped:
        return sprites, turn
    in_atlas = np.isin(sprites, atlas.ids)
    kept_by_class = {}
    for index in np.flatnonzero(~in_atlas):
        c = int(placed_classes[index])
        if c not in kept_by_class:
            kept_by_class[c] = np.sort(atlas.ids[atlas.classes == c])
        kept = kept_by_class[c]
        replacement = int(kept[int(sprites[index]) % kept.size])
        turn[index] = angles_by_sprite[sprites[index]] - angles_by_sprite[replacement]
        sprites[index] = replacement
    return sprites, turn


def rotate_in_plane(vectors, normals, angles):
    """Rotates tangent vectors about the normals by angles (radians, counter-clockwise seen from n)."""
    vectors = np.asarray(vectors, np.float64)
    normals = np.asarray(normals, np.float64)
    cos, sin = np.cos(angles)[:, None], np.sin(angles)[:, None]
    return vectors * cos + np.cross(normals, vectors) * sin


def decal_inputs(placed, analysis, atlas, sprite_boxes):
    """axes (n, 3), rects (n, 4) in world units around the anchor, uv_rects (n, 4) for decal_mesh.

    sprite_boxes: {particle id: (x0, y0, w, h)} of every atlas sprite (origin and size from particle_sprite).
    The anchor is the particle's box centre: a sprite covering sample x in [x0, x0 + w] around a box
    centre cx spans u in [(x0 - cx), (x0 + w - cx)] x pixel size along its axis."""
    classes = np.asarray(placed["class"], np.int32)
    angles = np.asarray(analysis.particles["box_angle"], np.float64)
    sprites, turn = substitute_sprites(placed["sprite"], classes, atlas, angles)
    axes = np.asarray(placed["sprite_axis"], np.float64)
    if np.any(turn):
        axes = rotate_in_plane(axes, placed["normal"], turn)
        axes /= np.maximum(np.linalg.norm(axes, axis=1, keepdims=True), 1e-30)
    centres = np.asarray(analysis.particles["box_centre"], np.float64)
    boxes = np.array([sprite_boxes[int(s)] for s in sprites], np.float64).reshape(-1, 4)
    size = np.asarray(placed["pixel_size"], np.float64)[:, None]
    c = centres[sprites] if sprites.size else np.zeros((0, 2))
    rects = np.column_stack([boxes[:, 0] - c[:, 0], boxes[:, 1] - c[:, 1], boxes[:, 0] + boxes[:, 2] - c[:, 0],
                             boxes[:, 1] + boxes[:, 3] - c[:, 1]]) * size
    return (np.ascontiguousarray(axes, np.float32), np.ascontiguousarray(rects, np.float32),
            atlas.uv_rects(sprites), sprites)


def decal_lift(rank, bbox_diagonal):
    """decal_mesh's offset, stack_step and max_level for the class of this rank."""
    unit = DECAL_OFFSET_FACTOR * float(bbox_diagonal)
    return dict(offset=(1.0 + DECAL_CLASS_BAND * rank) * unit, stack_step=DECAL_STACK_STEP * unit,
                max_level=DECAL_STACK_LEVELS)


def decal_lift_top(classes, bbox_diagonal):
    """The highest any decal of `classes` classes can lie above the surface."""
    top = decal_lift(classes - 1, bbox_diagonal)
    return top["offset"] + top["max_level"] * top["stack_step"]


def euler_xyz(x_axes, z_axes):
    """Blender XYZ Euler angles (n, 3) of the frames with columns X, Y = Z x X, Z (X re-orthogonalised)."""
    z = np.asarray(z_axes, np.float64)
    z = z / np.maximum(np.linalg.norm(z, axis=1, keepdims=True), 1e-30)
    x = np.asarray(x_axes, np.float64)
    x = x - np.sum(x * z, axis=1, keepdims=True) * z
    x = x / np.maximum(np.linalg.norm(x, axis=1, keepdims=True), 1e-30)
    y = np.cross(z, x)
    # R = Rz(c) Ry(b) Rx(a); columns x, y, z: R[2,0] = x.z = -sin b, R[2,1] = y.z, R[2,2] = z.z.
    b = np.arcsin(np.clip(-x[:, 2], -1.0, 1.0))
    cos_b = np.cos(b)
    regular = cos_b > 1e-6
    a = np.where(regular, np.arctan2(y[:, 2], z[:, 2]), np.arctan2(-z[:, 1], y[:, 1]))
    c = np.where(regular, np.arctan2(x[:, 1], x[:, 0]), 0.0)
    return np.ascontiguousarray(np.column_stack([a, b, c]), dtype=np.float32)


def instance_frames(placed, analysis):
    """rotation (n, 3) Euler XYZ with X along the particle's box axis and Z along the normal, and scale
    (n, 3) = box width, box height (world units) and their geometric mean (an object of unit size centred
    on its origin covers the particle's box; fit_instances fits others)."""
    sprites = np.asarray(placed["sprite"], np.int64)
    theta_s = np.asarray(analysis.particles["box_angle"], np.float64)[sprites] if sprites.size else np.zeros(0)
    box_axes = rotate_in_plane(placed["sprite_axis"], placed["normal"], theta_s)
    rotation = euler_xyz(box_axes, placed["normal"])
    half = np.asarray(analysis.particles["box_half"], np.float64)[sprites] if sprites.size else np.zeros((0, 2))
    size = np.asarray(placed["pixel_size"], np.float64)[:, None] * 2.0 * half
    scale = np.column_stack([size, np.sqrt(np.maximum(size[:, 0] * size[:, 1], 0.0))])
    return rotation, np.ascontiguousarray(scale, dtype=np.float32)


def fit_instances(position, axis, normal, scale, class_ids, child_bounds):
    """(position, axis, scale) that put each instanced object inside its particle's box, whatever size and
    origin it was modelled with: child_bounds[class % len] is that object's local (min xyz, max xyz), or
    None to place it as given (a unit object centred on its origin covers the box). The object keeps its
    proportions: turned a quarter about the normal when that lines its longer side up with the box's,
    scaled by one factor until its footprint meets the box's sides, and moved so the centres meet.
    Unfitted, a thorn modelled from its base to +Y reached half a box beyond its particle."""
    position = np.array(position, np.float64).reshape(-1, 3)
    axis = np.array(axis, np.float64).reshape(-1, 3)
    normal = np.asarray(normal, np.float64).reshape(-1, 3)
    scale = np.array(scale, np.float64).reshape(-1, 3)
    if not child_bounds or not len(position):
        return position.astype(np.float32), axis.astype(np.float32), scale.astype(np.float32)
    lower = np.zeros((len(child_bounds), 3))
    extent = np.ones((len(child_bounds), 3))
    fitted = np.zeros(len(child_bounds), bool)
    for index, bounds in enumerate(child_bounds):
        if bounds is None:
            continue
        low, high = np.asarray(bounds[0], np.float64), np.asarray(bounds[1], np.float64)
        size = high - low
        if np.all(np.isfinite(size)) and size[0] > 1e-9 and size[1] > 1e-9:
            lower[index], extent[index], fitted[index] = low, size, True
    child = np.asarray(class_ids, np.int64) % len(child_bounds)
    use = fitted[child]
    width, height = extent[child, 0], extent[child, 1]
    # A quarter turn (X -> the box's Y) when the object's longer side would lie across the box's longer side.
    turn = (width >= height) != (scale[:, 0] >= scale[:, 1])
    box_x = np.where(turn, scale[:, 1], scale[:, 0])
    box_y = np.where(turn, scale[:, 0], scale[:, 1])
    x_axis = np.where(turn[:, None], np.cross(normal, axis), axis)
    y_axis = np.cross(normal, x_axis)
    factor = np.minimum(box_x / width, box_y / height)
    centre = lower[child, :2] + 0.5 * extent[child, :2]
    shift = -(centre[:, 0] * factor)[:, None] * x_axis - (centre[:, 1] * factor)[:, None] * y_axis
    position = np.where(use[:, None], position + shift, position)
    axis = np.where(use[:, None], x_axis, axis)
    scale = np.where(use[:, None], np.repeat(factor[:, None], 3, axis=1), scale)
    return tuple(np.ascontiguousarray(a, np.float32) for a in (position, axis, scale))


def bbox_diagonal(positions):
    positions = np.asarray(positions, np.float64)
    if positions.size == 0:
        return 0.0
    return float(np.linalg.norm(positions.max(axis=0) - positions.min(axis=0)))


def triangle_areas(positions, triangles):
    p = np.asarray(positions, np.float64)[np.asarray(triangles, np.int64)]
    return 0.5 * np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1)
