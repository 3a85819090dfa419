# SPDX-License-Identifier: GPL-3.0-or-later
"""Regenerates blend_samples/: procedural sample textures (CC0-1.0) and the small scene.

Run: blender -b --factory-startup --python-exit-code 1 --python blend_samples/make_samples.py [-- NAME ...]
Deterministic (numpy Generator with fixed seeds, no external data).
"""
import os
import sys

import bpy
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))


def value_noise(rng, height, width, cell):
    """Smooth value noise tileable in both directions (bilinear-smoothstep on a random lattice)."""
    grid = rng.random((height // cell + 1, width // cell + 1))
    grid[-1, :], grid[:, -1] = grid[0, :], grid[:, 0]
    y = np.arange(height) / cell
    x = np.arange(width) / cell
    y0, x0 = np.floor(y).astype(int), np.floor(x).astype(int)
    fy, fx = y - y0, x - x0
    fy, fx = fy * fy * (3 - 2 * fy), fx * fx * (3 - 2 * fx)
    top = grid[y0][:, x0] * (1 - fx) + grid[y0][:, x0 + 1] * fx
    bottom = grid[y0 + 1][:, x0] * (1 - fx) + grid[y0 + 1][:, x0 + 1] * fx
    return top * (1 - fy[:, None]) + bottom * fy[:, None]


def fractal(rng, height, width, cells):
    total = sum(value_noise(rng, height, width, c) / (i + 1) for i, c in enumerate(cells))
    return (total - total.min()) / (total.max() - total.min())


def bricks(size=192, rows=8, columns=4, mortar=3):
    """Running-bond red bricks with per-brick tint and grain; row 0 = top."""
    rng = np.random.default_rng(1)
    height = width = size
    brick_h, brick_w = height // rows, width // columns
    y, x = np.mgrid[0:height, 0:width]
    row = y // brick_h
    shifted = (x + (row % 2) * (brick_w // 2)) % width
    column = shifted // brick_w
    in_mortar = ((y % brick_h) < mortar) | ((shifted % brick_w) < mortar)
    tint = rng.uniform(0.75, 1.15, size=(rows, columns + 1))[row, column]
    grain = fractal(rng, height, width, (4, 8, 16))
    base = np.array([0.55, 0.2, 0.12])
    color = base[None, None, :] * (tint * (0.8 + 0.4 * grain))[..., None]
    mortar_color = np.array([0.62, 0.6, 0.55]) * (0.85 + 0.3 * grain)[..., None]
    return np.where(in_mortar[..., None], mortar_color, color)


def moss(size=160):
    """Stochastic green moss: fractal noise plus speckles."""
    rng = np.random.default_rng(2)
    noise = fractal(rng, size, size, (5, 10, 20, 40))
    speckle = rng.random((size, size)) ** 8
    dark, light = np.array([0.08, 0.18, 0.04]), np.array([0.38, 0.55, 0.12])
    color = dark + (light - dark) * noise[..., None] + 0.25 * speckle[..., None] * np.array([0.8, 0.9, 0.3])
    return np.clip(color, 0, 1)


def bark(width=128, height=256):
    """Directional bark: vertically stretched noise ridges."""
    rng = np.random.default_rng(3)
    ridges = fractal(rng, height, width, (8, 16, 32))
    stretched = fractal(rng, height // 8, width, (2, 4, 8))
    stretched = np.repeat(stretched, 8, axis=0)
    furrows = np.abs(np.sin((np.arange(width)[None, :] / width) * np.pi * 10 + 6 * stretched)) ** 0.6
    value = 0.55 * furrows + 0.45 * ridges
    dark, light = np.array([0.12, 0.08, 0.05]), np.array([0.5, 0.38, 0.27])
    return dark + (light - dark) * value[..., None]


def pebbles(size=256):
    """Texture particles: grey pebbles (shaded ellipses, jittered hexagonal layout) with a few red berries on
    sand; tileable. Row 0 = top."""
    rng = np.random.default_rng(4)
    y, x = np.mgrid[0:size, 0:size] + 0.5
    sand = np.array([0.74, 0.63, 0.44]) * (0.85 + 0.3 * fractal(rng, size, size, (4, 8, 16)))[..., None]
    color = sand + 0.05 * rng.standard_normal((size, size, 1))
    step = size / 8.0
    for row in range(9):
        for col in range(9):
            cx = (col + 0.5 * (row % 2)) * step + rng.uniform(-3, 3)
            cy = row * step * 0.866 + rng.uniform(-3, 3)
            a = rng.uniform(0.30, 0.40) * step
            b, t = a * rng.uniform(0.6, 0.85), rng.uniform(0, np.pi)
            tone = np.array([0.42, 0.41, 0.43]) * rng.uniform(0.92, 1.08)
            for ox in (-size, 0, size):  # tileable: every copy across the borders
                for oy in (-size, 0, size):
                    dx, dy = x - cx - ox, y - cy - oy
                    u = (dx * np.cos(t) + dy * np.sin(t)) / a
                    v = (-dx * np.sin(t) + dy * np.cos(t)) / b
                    r2 = u * u + v * v
                    inside = r2 <= 1.0
                    if inside.any():
                        # lit from the top left, darker rim: reads as a rounded stone
                        shade = 0.88 + 0.17 * np.sqrt(np.clip(1 - r2, 0, 1))
                        light = 1.0 + 0.08 * (-(dx + dy) / (a + b))
                        color[inside] = (tone * (shade * light)[..., None])[inside]
    for _ in range(30):
        cx, cy = rng.uniform(0, size, 2)
        for ox in (-size, 0, size):
            for oy in (-size, 0, size):
                d = np.hypot(x - cx - ox, y - cy - oy)
                berry = (d <= 5.5) & (np.abs(color - sand).sum(-1) < 0.35)
                color[berry] = np.array([0.62, 0.10, 0.07]) * (1.1 - 0.25 * d[berry, None] / 5.5)
    return np.clip(color, 0, 1)


def save_png(name, rgb):
    height, width, _ = rgb.shape
    rgba = np.concatenate([rgb, np.ones((height, width, 1))], axis=2).astype(np.float32)
    image = bpy.data.images.new(name, width, height, alpha=False)
    image.pixels.foreach_set(np.ascontiguousarray(rgba[::-1]).ravel())  # Blender rows are bottom-up
    path = os.path.join(HERE, name + ".png")
    image.filepath_raw = path
    image.file_format = "PNG"
    image.save()
    bpy.data.images.remove(image)
    return path


def make_scene():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    bpy.ops.mesh.primitive_monkey_add(size=2.0, location=(0, 0, 1.0))
    monkey = bpy.context.active_object
    monkey.name = monkey.data.name = "Suzanne"
    monkey.rotation_euler = (0.0, 0.0, 0.35)
    bpy.ops.object.shade_smooth()
    modifier = monkey.modifiers.new("Subdivision", "SUBSURF")
    modifier.levels = modifier.render_levels = 1
    # A grid, not a single quad: each face must stay smaller than the sample at the demo scale.
    bpy.ops.mesh.primitive_grid_add(x_subdivisions=24, y_subdivisions=24, size=8.0, location=(0, 0, 0))
    ground = bpy.context.active_object
    ground.name = ground.data.name = "Ground"
    ground_material = bpy.data.materials.new("Ground")
    ground_material.use_nodes = True
    principled = ground_material.node_tree.nodes["Principled BSDF"]
    principled.inputs["Base Color"].default_value = (0.3, 0.3, 0.28, 1.0)
    principled.inputs["Roughness"].default_value = 0.9
    ground.data.materials.append(ground_material)
    bpy.ops.object.camera_add(location=(4.2, -5.6, 3.4))
    camera = bpy.context.active_object
    camera.name = "Camera"
    direction = np.array([0, 0, 0.9]) - np.array(camera.location)
    camera.rotation_euler = direction_to_euler(direction)
    scene.camera = camera
    bpy.ops.object.light_add(type="SUN", location=(3, -2, 6))
    sun = bpy.context.active_object
    sun.name = "Sun"
    sun.data.energy = 3.0
    sun.rotation_euler = (0.6, 0.2, 0.9)
    world = bpy.data.worlds.new("World")
    world.use_nodes = True
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.35, 0.4, 0.5, 1.0)
    world.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.6
    scene.world = world
    scene.render.engine = "BLENDER_EEVEE"
    scene.render.resolution_x, scene.render.resolution_y = 320, 240
    scene.render.resolution_percentage = 100
    scene.eevee.taa_render_samples = 16
    scene.render.film_transparent = False
    scene.view_settings.view_transform = "Standard"
    bpy.ops.wm.save_as_mainfile(filepath=os.path.join(HERE, "scene.blend"), compress=True)


def direction_to_euler(direction):
    from mathutils import Vector
    return Vector(direction).to_track_quat("-Z", "Y").to_euler()


MAKERS = {"bricks": bricks, "moss": moss, "bark": bark, "pebbles": pebbles}


def main():
    # Names after "--" regenerate only those assets (e.g. -- pebbles); none: everything.
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    for name in argv or list(MAKERS) + ["scene"]:
        if name == "scene":
            make_scene()
        else:
            save_png(name, MAKERS[name]())
    print("blend_samples regenerated in", HERE)


if __name__ == "__main__":
    main()
