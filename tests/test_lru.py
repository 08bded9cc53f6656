"""The scenes' and plates' cache (squeezebench.lru) against a plain model of an LRU."""

import threading

import pytest
from hypothesis import given
from hypothesis import strategies as st

from squeezebench.lru import RecentlyUsed


@given(size=st.integers(1, 4), keys=st.lists(st.integers(0, 6), max_size=40))
def test_it_keeps_the_most_recently_used_and_builds_only_what_it_lacks(size, keys):
    cache, model, builds = RecentlyUsed(size), [], []   # model: the keys kept, least recent first
    for key in keys:
        before = len(builds)
        value = cache.get(key, lambda key=key: builds.append(key) or f"value {key} #{len(builds)}")
        missed = key not in model
        assert len(builds) == before + missed
        if not missed:
            model.remove(key)
        model.append(key)
        del model[:-size]
        assert value.startswith(f"value {key} ")
        assert len(cache) == len(model) <= size


def test_a_build_that_raises_keeps_nothing():
    cache = RecentlyUsed(2)
    with pytest.raises(ValueError):
        cache.get("scene", lambda: (_ for _ in ()).throw(ValueError("refused")))
    assert len(cache) == 0 and cache.get("scene", lambda: 1) == 1


def test_two_threads_building_one_key_get_the_same_value():
    cache, started = RecentlyUsed(2), threading.Barrier(2)
    found = []

    def build():
        started.wait()   # both build at once
        return object()

    threads = [threading.Thread(target=lambda: found.append(cache.get("plate", build))) for _ in range(2)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert found[0] is found[1] and len(cache) == 1


def test_a_size_below_one_is_refused():
    with pytest.raises(ValueError, match="at least 1"):
        RecentlyUsed(0)


@given(limit=st.integers(1, 20), weights=st.lists(st.tuples(st.integers(0, 6), st.integers(1, 12)), max_size=40))
def test_with_a_byte_limit_it_drops_the_least_recent_until_the_rest_fit(limit, weights):
    """Against a model: the most recent keys whose weights sum within the limit (the newest
    always, whatever it weighs), at most `size` of them."""
    cache, model = RecentlyUsed(4, max_bytes=limit, weigh=lambda value: value[1]), []   # (key, weight)
    for key, weight in weights:
        kept = cache.get(key, lambda: (key, weight))
        model = [entry for entry in model if entry[0] != key] + [kept]
        while len(model) > 4 or (len(model) > 1 and sum(w for _, w in model) > limit):
            model.pop(0)
        assert len(cache) == len(model) and cache.bytes == sum(w for _, w in model)
        assert cache.bytes <= limit or len(cache) == 1


def test_a_byte_limit_needs_a_weight():
    with pytest.raises(ValueError, match="together"):
        RecentlyUsed(2, max_bytes=10)
