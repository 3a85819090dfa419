# SPDX-License-Identifier: GPL-3.0-or-later
"""texsynth_native.place_particles: the output dict of the plan (names, dtypes, shapes), a grid of squares
reproduced on a plane in world units and turned by the field, shapes and values checked at the boundary,
cancel and progress through a CancelToken, the GIL released while it runs; a sample whose pebbles differ only
in brightness keeps its density and class shares however many classes split it (issue 30),
output_classes gives one class's rows of the full run, and the local count control spreads a class that
overpacks over the whole surface."""
import math
import threading
import time

import numpy as np
import pytest

from pebble_samples import brightness_labels, pebble_field

from mesh_arrays import jittered_plane

tn = pytest.importorskip("texsynth_native")

STEP = 0.28  # 20 px squares 8 px apart at 0.01 world units per pixel


def square_grid(n=6, side=20, gap=8):
    """Labels (row 0 = bottom) of n x n squares of class 1, 14 px from the edges; the sample follows them."""
    w = 28 + n * side + (n - 1) * gap
    labels = np.zeros((w, w), np.int32)
    for j in range(n):
        for i in range(n):
            x, y = 14 + i * (side + gap), 14 + j * (side + gap)
            labels[y:y + side, x:x + side] = 1
    sample = np.where(labels[..., None] == 1, [0.8, 0.7, 0.3], [0.2, 0.3, 0.25]).astype(np.float32)
    return tn.particle_analysis(sample, labels=labels, background=0)


@pytest.fixture(scope="module")
def scene():
    pos, tris = jittered_plane(n=60, spacing=0.1, jitter=0.0)  # 6 x 6 world units, exact border
    return square_grid(), tn.surface_walk_mesh(pos, tris), pos, tris


def field(pos, degrees):
    """'up' turned by `degrees` from +y at every vertex."""
    a = math.radians(90 + degrees)
    return np.tile(np.array([math.cos(a), math.sin(a), 0], np.float32), (len(pos), 1))


def place(scene, degrees=0.0, **kwargs):
    a, mesh, pos, _ = scene
    return tn.place_particles(a, mesh, field(pos, degrees), sample_world_width=0.01 * a.width, **kwargs)


@pytest.mark.parametrize("degrees", [0.0, 30.0])
def test_plane_reproduces_the_grid_turned_by_the_field(scene, degrees):
    out = place(scene, degrees)
    n = len(out["class"])
    want = {"class": (np.int32, (n,)), "sprite": (np.int32, (n,)), "parent": (np.int32, (n,)),
            "triangle": (np.int32, (n,)), "barycentric": (np.float64, (n, 2)), "position": (np.float32, (n, 3)),
            "normal": (np.float32, (n, 3)), "sprite_axis": (np.float32, (n, 3)), "pixel_size": (np.float32, (n,)),
            "angle": (np.float32, (n,)), "origin": (np.uint8, (n,))}
    for key, (dtype, shape) in want.items():
        assert out[key].dtype == dtype and out[key].shape == shape, key
    assert n > 300
    # Centres on the lattice of step 0.28 along the field's right / up axes through the seed (3, 3).
    a = math.radians(degrees)
    right, up = np.array([math.cos(a), math.sin(a)]), np.array([-math.sin(a), math.cos(a)])
    d = out["position"][:, :2].astype(np.float64) - out["position"][0, :2]
    uv = np.stack([d @ right, d @ up], axis=1) / STEP
    assert np.abs(uv - np.round(uv)).max() * STEP < 1e-4
    assert len({tuple(c) for c in np.round(uv).astype(int)}) == n
    # The seed: the plane's area centroid (it lies on the plane).
    _, _, pos, tris = scene
    corners = pos[tris].astype(np.float64)
    area = 0.5 * np.abs(np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])[:, 2])
    np.testing.assert_allclose(out["position"][0], (area[:, None] * corners.mean(1)).sum(0) / area.sum(), atol=1e-6)
    # Every lattice point inside the plane is taken once.
    i, j = np.mgrid[-40:41, -40:41]
    pts = out["position"][0, :2] + STEP * (i.ravel()[:, None] * right + j.ravel()[:, None] * up)
    inside = np.all((pts > 1e-6) & (pts < 6 - 1e-6), axis=1).sum()
    assert n == inside
    np.testing.assert_allclose(out["sprite_axis"][:, :2], np.tile(right, (n, 1)), atol=1e-5)
    np.testing.assert_allclose(out["normal"], np.tile([0, 0, 1], (n, 1)), atol=1e-6)
    np.testing.assert_allclose(out["pixel_size"], 0.01, rtol=1e-6)
    assert (out["class"] == 1).all() and out["parent"][0] == -1 and (out["parent"][1:] < np.arange(1, n)).all()
    assert [tn.placement_origins[o] for o in np.unique(out["origin"])] == ["seed", "propagated"]
    stats = out["stats"]
    assert stats["components"] == 1 and not stats["capped"] and stats["seconds"] > 0 and stats["walks"] > n
    (cls,) = stats["classes"]
    assert cls["class"] == 1 and cls["placed"] == n and cls["hidden"] == 0 and cls["rejected_overlap"] > 0


def test_overrides_seeds_and_cap(scene):
    a, mesh, pos, tris = scene
    T = len(tris)
    out = place(scene, face_size=np.full(T, 2.0), seed_triangles=[10], seed_barycentrics=[[0.2, 0.3]],
                max_particles=50)
    p = pos[tris[10]].astype(np.float64)
    np.testing.assert_allclose(out["position"][0], 0.5 * p[0] + 0.2 * p[1] + 0.3 * p[2], atol=1e-6)
    np.testing.assert_allclose(out["pixel_size"], 0.02, rtol=1e-6)
    assert len(out["class"]) == 50 and out["stats"]["capped"]
    hidden = place(scene, face_probability=np.zeros(T))
    assert len(hidden["class"]) == 0 and hidden["stats"]["classes"][0]["hidden"] > 300


@pytest.mark.parametrize("kwargs, message", [
    ({"directions": np.zeros((5, 3))}, "directions must have shape"),
    ({"vertex_scale": np.ones(7)}, "vertex_scale must have shape"),
    ({"face_density": np.ones((3, 2))}, "face_density must have shape"),
    ({"face_probability": np.full(7200, 1.5)}, "face_probability"),
    ({"vertex_scale": np.zeros(3721)}, "vertex_scale"),
    ({"sample_world_width": -1.0}, "sample_world_width"),
    ({"size_jitter": 1.0}, "size_jitter"),
    ({"classes": [0]}, "background"),
    ({"classes": [5]}, "unknown class"),
    ({"classes": []}, "at least one class"),
    ({"output_classes": []}, "at least one class"),
    ({"classes": [1], "output_classes": [2]}, "output class 2 is not placed"),
    ({"seed_triangles": [0]}, "go together"),
    ({"seed_triangles": [0], "seed_barycentrics": [[0.1, 0.1, 0.1]]}, "seed_barycentrics must have shape"),
    ({"seed_triangles": [99999], "seed_barycentrics": [[0.1, 0.1]]}, "seed 0"),
    ({"max_particles": 0}, "max_particles"),
    ({"progress": "fast"}, "CancelToken"),
])
def test_bad_arguments_raise_value_error(scene, kwargs, message):
    a, mesh, pos, _ = scene
    args = {"directions": field(pos, 0), "sample_world_width": 0.01 * a.width}
    args.update(kwargs)
    directions = args.pop("directions")
    with pytest.raises(ValueError, match=message):
        tn.place_particles(a, mesh, directions, **args)


def test_cancel_progress_and_gil(scene):
    token = tn.CancelToken()
    token.cancel()
    with pytest.raises(tn.Cancelled):
        place(scene, cancel=token)
    progress = tn.CancelToken()
    place(scene, progress=progress)
    assert progress.progress == pytest.approx(1.0)
    # A long run in a thread: this thread keeps running meanwhile (GIL released) and cancels it.
    a, _, _, _ = scene
    pos, tris = jittered_plane(n=200, spacing=0.05, jitter=0.3)
    mesh = tn.surface_walk_mesh(pos, tris)
    token = tn.CancelToken()
    caught = []

    def run():
        try:
            tn.place_particles(a, mesh, field(pos, 0), sample_world_width=0.0008 * a.width, cancel=token)
        except tn.Cancelled:
            caught.append(True)

    worker = threading.Thread(target=run)
    worker.start()
    ticks = 0
    while token.progress < 0.05 and worker.is_alive():
        ticks += 1
        time.sleep(0.001)
    token.cancel()
    worker.join(5)
    assert caught == [True] and ticks > 0


def hostile_meshes():
    """(name, positions, triangles) that must end in a result or a ValueError, never a crash."""
    pos, tris = jittered_plane(n=6, spacing=0.5, jitter=0.2)
    yield "coords_1e30", pos * np.float32(1e30), tris
    yield "coords_1e-30", pos * np.float32(1e-30), tris
    yield "zero_area", np.zeros((3, 3), np.float32), np.array([[0, 1, 2]], np.int32)
    yield "one_triangle", np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], np.float32), np.array([[0, 1, 2]], np.int32)
    flipped = tris.copy()
    flipped[::3] = flipped[::3, ::-1]
    yield "inconsistent_winding", pos, flipped
    fan = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1]], np.float32)
    yield "nonmanifold_fan", fan, np.array([[0, 1, 2], [0, 1, 3], [0, 1, 4]], np.int32)
    yield "sliver", np.array([[0, 0, 0], [1, 0, 0], [0.5, 1e-9, 0]], np.float32), np.array([[0, 1, 2]], np.int32)


@pytest.mark.parametrize("name, pos, tris", list(hostile_meshes()), ids=[m[0] for m in hostile_meshes()])
def test_hostile_meshes_give_a_result_or_value_error(scene, name, pos, tris):
    a = scene[0]
    try:
        mesh = tn.surface_walk_mesh(pos, tris)
        out = tn.place_particles(a, mesh, field(pos, 0), sample_world_width=0.01 * a.width, max_particles=20000)
    except ValueError as e:
        assert "placement" in str(e) or "mesh" in str(e)
        return
    assert np.isfinite(out["position"]).all() and np.isfinite(out["sprite_axis"]).all()
    assert ((out["triangle"] >= 0) & (out["triangle"] < len(tris))).all()


def test_same_seed_same_bytes_other_seed_other_draws(scene):
    a, _, _, tris = scene
    kwargs = {"size_jitter": 0.2, "face_probability": np.full(len(tris), 0.8)}
    first, again, other = place(scene, **kwargs), place(scene, **kwargs), place(scene, seed=1, **kwargs)
    for key in ("class", "sprite", "parent", "triangle", "barycentric", "position", "sprite_axis", "pixel_size"):
        assert first[key].tobytes() == again[key].tobytes(), key
    assert first["sprite"].tobytes() != other["sprite"].tobytes()
    assert first["pixel_size"].tobytes() != other["pixel_size"].tobytes()


@pytest.fixture(scope="module")
def pebbles():
    pos, tris = jittered_plane(n=60, spacing=0.1, jitter=0.3)
    return pebble_field(), tn.surface_walk_mesh(pos, tris), pos


@pytest.mark.parametrize("k", [1, 2, 3, 4])
def test_brightness_classes_keep_the_sample_density_and_shares(pebbles, k):
    """Issue 30: 60 pebbles per 256^2 split by brightness into k classes give the same total density (the
    field's, +-15 %) and each class its share of the sample's particles (+-15 %). Before: 1.86 x with one
    class, 3.10 x with two (shares 0.78 and 1.21 x the sample's); three and four were scattered classes
    (dart throwing at their density: 1.06 and 1.05 x) that overlapped each other freely."""
    (sample, element, brightness), mesh, pos = pebbles
    a = tn.particle_analysis(sample, labels=brightness_labels(element, brightness, k), background=0)
    pixel = 0.004
    out = tn.place_particles(a, mesh, field(pos, 0), sample_world_width=pixel * a.width)
    xy = out["position"][:, :2]
    inside = np.all((xy >= 0.5) & (xy < 5.5), axis=1)
    density = inside.sum() / (25.0 / pixel ** 2)
    assert density / (60 / 256 ** 2) == pytest.approx(1.0, abs=0.15)
    classes = a.particles["class"]
    for c in range(1, k + 1):
        share, want = (out["class"][inside] == c).mean(), (classes == c).mean()
        assert share / want == pytest.approx(1.0, abs=0.15), c
    for row in out["stats"]["classes"]:
        assert row["expected"] > 0 and row["thinned"] >= 0 and row["filled"] >= 0
        assert row["placed"] == np.count_nonzero(out["class"] == row["class"])
    assert set(tn.placement_origins) >= {"seed", "propagated", "reseeded", "random_class", "filled"}


def pebble_pieces(element):
    """The pebbles' 8-connected pieces in the crop (the border cuts some pebbles into two or four)."""
    pieces = 0
    for e in range(element.max() + 1):
        todo = set(zip(*np.nonzero(element == e)))
        while todo:
            stack = [todo.pop()]
            while stack:
                y, x = stack.pop()
                for dy in (-1, 0, 1):
                    for dx in (-1, 0, 1):
                        if (y + dy, x + dx) in todo:
                            todo.remove((y + dy, x + dx))
                            stack.append((y + dy, x + dx))
            pieces += 1
    return pieces


@pytest.mark.parametrize("k", [1, 2, 3, 4])
def test_kmeans_classes_at_the_default_blur_count_each_pebble_once(pebbles, k):
    """Issue 30, at the add-on's defaults (k-means, blur 1, Touching Elements Auto): k-means also classes the
    band of in-between brightness at the pebbles' edges, and each core with its ring came out as two particles
    (117 / 162 / 169 for 60 pebbles at 2 / 3 / 4 classes, the placed density 1.9-2.95 x). Rims now join their
    pebble: as many particles as pebble pieces (+-10 %) and the field's density (+-15 %)."""
    (sample, element, brightness), mesh, pos = pebbles
    a = tn.particle_analysis(sample, classes=k + 1, blur=1.0, seed=0, touching="auto")
    pieces = pebble_pieces(element)
    assert abs(len(a.particles) - pieces) <= 0.1 * pieces, (len(a.particles), pieces)
    pixel = 0.004
    out = tn.place_particles(a, mesh, field(pos, 0), sample_world_width=pixel * a.width)
    xy = out["position"][:, :2]
    density = np.all((xy >= 0.5) & (xy < 5.5), axis=1).sum() / (25.0 / pixel ** 2)
    assert density / (60 / 256 ** 2) == pytest.approx(1.0, abs=0.15)


def test_class_pairs_and_one_class_rerun(pebbles):
    """class_pairs: (k, k) symmetric, what the sample shows between two classes; output_classes = [c] gives
    class c's rows of the full run (the classes before it constrain it)."""
    (sample, element, brightness), mesh, pos = pebbles
    a = tn.particle_analysis(sample, labels=brightness_labels(element, brightness, 2), background=0)
    pairs = a.class_pairs
    for key in ("pairs", "tolerance", "margin"):
        assert pairs[key].shape == (3, 3) and (pairs[key] == pairs[key].T).all(), key
    assert pairs["pairs"][1, 2] > 10 and 0 < pairs["tolerance"][1, 2] < 0.1  # pebbles 4 px apart: no overlap
    assert pairs["tolerance"][1, 1] == a.classes["tolerance"][1]
    args = dict(sample_world_width=0.006 * a.width, classes=[2, 1])
    full = tn.place_particles(a, mesh, field(pos, 0), **args)
    one = tn.place_particles(a, mesh, field(pos, 0), output_classes=[1], **args)
    assert (one["class"] == 1).all() and len(one["class"]) > 50
    np.testing.assert_array_equal(one["position"], full["position"][full["class"] == 1])
    assert [row["class"] for row in one["stats"]["classes"]] == [1]


def paving_bricks_plane():
    """The corpus' paving_bricks (committed) at the add-on's defaults, and a plane of 3 x 3 sample widths with
    the field along +y: (analysis, sample width in world units, walk mesh, field)."""
    import paths
    sample = np.ascontiguousarray(np.asarray(tn.load_image(paths.BENCH + "/placement_paving_bricks.png"),
                                             np.float32)[..., :3])
    a = tn.particle_analysis(sample, classes=4, blur=1.0, seed=0, tileable=False)
    width = sample.shape[1] / 512.0
    pos, tris = jittered_plane(n=150, spacing=3 * width / 150, jitter=0.0)
    field = np.tile(np.array([0.0, 1.0, 0.0], np.float32), (len(pos), 1))
    return a, width, tn.surface_walk_mesh(pos, tris), field


def test_local_count_control_spreads_a_class_over_the_whole_surface():
    """Issue 30: on the corpus' paving_bricks at the add-on's defaults the propagation packs 4-6 x the expected
    count, so from its one seed each class reached its cap in a disc round the seed and the thinning kept that
    disc (measured on this plane without the local count control: 1.38 x the whole plane's density in its
    middle, every class capped; with it 1.10, none capped). Plane of 3 x 3 sample widths; the middle is the
    central 2 x 2."""
    a, width, mesh, field = paving_bricks_plane()
    placed = tn.place_particles(a, mesh, field, sample_world_width=width, seed=1)
    p = placed["position"]
    middle = ((p[:, 0] >= 0.5 * width) & (p[:, 0] < 2.5 * width) & (p[:, 1] >= 0.5 * width) &
              (p[:, 1] < 2.5 * width)).sum() / 4.0
    ratio = middle / (len(p) / 9.0)
    classes = placed["stats"]["classes"]
    assert sum(c["crowded"] for c in classes) > 0 and not any(c["capped"] for c in classes), classes
    assert 0.85 <= ratio <= 1.2, ratio


def test_thinning_takes_the_excess_where_the_propagation_packed_it():
    """Issue 30: the propagation still packs more round its seeds than elsewhere (within the local count
    control's 1.3 x), and a class over its expected count was thinned uniformly, which kept that excess: on the
    paving_bricks plane the middle 2 x 2 sample widths held 1.10 x the whole plane's density (seeds 1-3: 1.10,
    1.09, 1.12; centre cell 1.17, 1.16, 1.11). Thinning now drops particles with a chance that rises with
    their local count ratio: 0.98-0.99, centre cell 0.96-1.05."""
    a, width, mesh, field = paving_bricks_plane()
    middles, centres = [], []
    for seed in (1, 2, 3):
        placed = tn.place_particles(a, mesh, field, sample_world_width=width, seed=seed)
        assert sum(c["thinned"] for c in placed["stats"]["classes"]) > 0  # the thinning is what is tested
        p = placed["position"][:, :2] / width
        per_cell = len(p) / 9.0
        middles.append(np.all((p >= 0.5) & (p < 2.5), axis=1).sum() / 4.0 / per_cell)
        centres.append(np.all((p >= 1.0) & (p < 2.0), axis=1).sum() / per_cell)
    assert abs(np.mean(middles) - 1.0) <= 0.05, middles
    assert np.mean(centres) <= 1.08, centres
