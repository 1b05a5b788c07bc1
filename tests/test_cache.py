import numpy as np

import wrinkle_vis as wv
from wrinkle_vis.core import restgeometry
from wrinkle_vis.core.cache import ByteBudgetCache, nbytes


def test_nbytes_counts_arrays_once_through_containers_and_objects():
    a = np.zeros(100)
    b = np.zeros((10, 10), np.float32)

    class Box:
        def __init__(self):
            self.a, self.items = a, [b, {"again": a}, a[:10]]

    assert nbytes(Box()) == a.nbytes + b.nbytes  # a counted once, the view not at all


def test_an_object_that_lists_its_arrays_weighs_those_not_what_it_refers_to():
    own, shared = np.zeros(50), np.zeros(1000)

    class Rows:
        def __init__(self):
            self.own, self.source = own, {"shared": shared}

        def arrays(self):
            return [self.own]

    assert nbytes(Rows()) == own.nbytes
    assert nbytes([Rows(), shared]) == own.nbytes + shared.nbytes


def test_the_cache_keeps_its_budget_in_bytes_dropping_the_least_recently_used():
    cache = ByteBudgetCache(2500)
    made = []
    for k in range(5):
        cache.get(k, lambda k=k: made.append(k) or np.zeros(100))  # 800 bytes each
        assert cache.total <= 2500
    assert len(cache) == 3 and made == [0, 1, 2, 3, 4]
    cache.get(2, lambda: made.append("again"))  # a hit: not rebuilt, now the newest
    cache.get(5, lambda: np.zeros(100))
    assert made[-1] != "again" and 3 not in cache._entries and 2 in cache._entries


def test_an_entry_that_grows_is_weighed_again_and_the_newest_stays_even_alone():
    cache = ByteBudgetCache(1000)
    holder = {"x": np.zeros(10)}
    cache.get("a", lambda: holder)
    holder["y"] = np.zeros(1000)  # grew lazily after it was made
    cache.reweigh("a")
    assert cache.total == 8080 and len(cache) == 1  # over budget, but the only one


def test_refined_frames_of_an_animation_stay_within_the_byte_budget(monkeypatch):
    monkeypatch.setattr(restgeometry, "REFINE_CACHE_BYTES", 2 * 2**20)
    face = wv.datasets.load_face()
    names = ("surprise", "fear", "frown")
    for i in range(12):
        face.evaluate(names[i % 3], intensity=0.3 + 0.05 * i, refine=True)
        cache = face._rest.engine(3).cache
        assert cache.total <= 2 * 2**20 or len(cache) == 1  # only an entry over budget
    assert len(cache) >= 1
    # the frames still agree with a face whose cache never dropped anything
    monkeypatch.setattr(restgeometry, "REFINE_CACHE_BYTES", 2**40)
    fresh = wv.datasets.load_face(n_triangles=face.skin.n_triangles)
    a = face.evaluate("fear", 0.8, refine=True)
    b = fresh.evaluate("fear", 0.8, refine=True)
    np.testing.assert_array_equal(a.points, b.points)
