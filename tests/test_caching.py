"""Kept tables (mitsonar.caching)."""

from mitsonar.caching import kept


def test_a_value_is_computed_once_and_the_cache_bounded():
    calls = []

    def compute(x):
        calls.append(x)
        return x * x

    cache = {}
    assert [kept(cache, k, 2, lambda k=k: compute(k)) for k in (3, 3, 4, 3)] == [9, 9, 16, 9]
    assert calls == [3, 4]  # each key computed once while it is kept
    assert kept(cache, 5, 2, lambda: compute(5)) == 25 and list(cache) == [5]  # full: emptied
    assert kept(cache, 3, 2, lambda: compute(3)) == 9 and calls == [3, 4, 5, 3]
