# SPDX-License-Identifier: GPL-3.0-or-later
"""texsynth_native.particle_analysis / particle_sprite: shapes checked at the boundary, a small sample of
squares round-trips (labels, components, particle table, co-occurrence CSR, background, sprites), and bad
input raises ValueError naming the problem."""
import numpy as np
import pytest

tn = pytest.importorskip("texsynth_native")

GROUND = np.array([0.2, 0.3, 0.25], np.float32)
STONE = np.array([0.8, 0.7, 0.3], np.float32)


def squares(width=96, height=64):
    """Three 12 px squares on a flat ground, rows bottom-first (row 0 = bottom)."""
    img = np.tile(GROUND, (height, width, 1))
    for x0, y0 in [(10, 10), (40, 10), (70, 30)]:
        img[y0:y0 + 12, x0:x0 + 12] = STONE
    return img


def test_small_sample_round_trips():
    img = squares()
    a = tn.particle_analysis(img, classes=2, blur=0.0)
    assert (a.width, a.height, a.channels, a.num_classes) == (96, 64, 3, 2)
    assert a.labels.shape == (64, 96) and a.labels.dtype == np.int32
    comp = a.components
    assert comp.shape == (64, 96) and comp.dtype == np.int32
    p = a.particles
    assert len(p) == 3
    # Ids follow row-major order from the bottom row; square (70, 30) is the last.
    assert comp[15, 15] == 0 and comp[15, 45] == 1 and comp[35, 75] == 2 and comp[0, 0] == -1
    np.testing.assert_array_equal(p["area"], [144, 144, 144])
    np.testing.assert_array_equal(p["bbox"][2], [70, 30, 81, 41])
    np.testing.assert_allclose(p["centroid"][0], [16.0, 16.0])
    np.testing.assert_allclose(p["box_half"], 6.0)
    assert p["complete"].all()
    cls = a.classes
    assert len(cls) == 2 and cls["background"][a.background_class]
    stone = 1 - a.background_class
    np.testing.assert_allclose(cls["colour"][stone], STONE, atol=1e-6)
    assert cls["random"][stone] and cls["particles"][stone] == 3
    co = a.cooccurrences
    assert co["start"].shape == (4,) and co["start"][0] == 0 and co["start"][-1] == len(co["dx"])
    for key in ("quadrant", "dx", "dy", "angle", "neighbour", "mirrored"):
        assert co[key].shape == (co["start"][-1],)
    bg = a.background
    assert bg.shape == img.shape and bg.dtype == np.float32
    np.testing.assert_allclose(bg, np.broadcast_to(GROUND, img.shape))  # flat ground fills flat
    s = tn.particle_sprite(a, img, 2)
    assert s["rgba"].shape == (16, 16, 4) and s["origin"] == (68, 28)
    assert (s["rgba"][2:14, 2:14, 3] == 1).all() and s["rgba"][0, 0, 3] < 0.1
    assert set(a.stats) >= {"seconds_kmeans", "seconds_cooccurrence", "seconds_total"}


def test_co_occurrence_row_of_squares():
    img = np.tile(GROUND, (48, 176, 1))
    for i in range(7):
        img[16:32, 8 + 24 * i:24 + 24 * i] = STONE
    a = tn.particle_analysis(img, classes=2, blur=0.0)
    co = a.cooccurrences
    mid = slice(co["start"][3], co["start"][4])
    # Neighbours 8 px along the row whose y-extents coincide: (8, -16) in every quadrant.
    assert sorted(co["quadrant"][mid]) == [0, 1, 2, 3]
    np.testing.assert_allclose(co["dx"][mid], 8, atol=1e-4)
    np.testing.assert_allclose(co["dy"][mid], -16, atol=1e-4)
    assert sorted(co["mirrored"][mid]) == [0, 0, 1, 1]


def test_labels_replace_kmeans_and_are_shape_checked():
    img = squares()
    labels = np.zeros((64, 96), np.int64)
    labels[5:25, 5:25] = 3
    a = tn.particle_analysis(img, labels=labels)
    assert a.num_classes == 4 and len(a.particles) == 1 and a.particles["area"][0] == 400
    with pytest.raises(ValueError, match=r"labels must have shape \(64, 96\)"):
        tn.particle_analysis(img, labels=labels[:, :90])
    with pytest.raises(ValueError, match="labels must hold integers"):
        tn.particle_analysis(img, labels=labels.astype(np.float32))


@pytest.mark.parametrize("kwargs, message", [
    ({"classes": 1}, "classes must be in 2..12"),
    ({"classes": 13}, "classes must be in 2..12"),
    ({"blur": -1.0}, "blur sigma"),
    ({"min_area": 0}, "min_area"),
    ({"background": 7}, "background class 7 is out of range"),
])
def test_bad_parameters_raise_value_error(kwargs, message):
    with pytest.raises(ValueError, match=message):
        tn.particle_analysis(squares(), **kwargs)


def test_bad_samples_raise_value_error():
    with pytest.raises(ValueError, match="shape \\(height, width, channels\\)"):
        tn.particle_analysis(np.zeros((64, 96), np.float32))
    with pytest.raises(ValueError, match="3 or 4 channels"):
        tn.particle_analysis(np.zeros((64, 96, 2), np.float32))
    with pytest.raises(ValueError, match="too small"):
        tn.particle_analysis(np.zeros((4, 96, 3), np.float32))
    bad = squares()
    bad[3, 5, 1] = np.nan
    with pytest.raises(ValueError, match=r"\(5, 3\) is NaN"):
        tn.particle_analysis(bad)
    a = tn.particle_analysis(squares(), classes=2, blur=0.0)
    with pytest.raises(ValueError, match="out of range"):
        tn.particle_sprite(a, squares(), 3)
    with pytest.raises(ValueError, match="must be the analysed one"):
        tn.particle_sprite(a, squares(80, 64), 0)


def test_raised_cancel_token_stops_the_analysis():
    token = tn.CancelToken()
    token.cancel()
    with pytest.raises(tn.Cancelled):
        tn.particle_analysis(squares(), cancel=token)
