import os

from hypothesis import HealthCheck, settings

# CI draws the same examples every run (a fixed budget, no flakes); "thorough" explores
settings.register_profile("ci", max_examples=25, deadline=None, derandomize=True,
                          suppress_health_check=[HealthCheck.too_slow])
settings.register_profile("thorough", max_examples=300, deadline=None,
                          suppress_health_check=[HealthCheck.too_slow])
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))


def pytest_collection_modifyitems(config, items):
    # pytest-xdist (the README's --dist loadfile --no-loadscope-reorder) hands out test
    # files in collection order: the long files (marked slow) go first, so that no worker
    # is left alone with one of them at the end while the other idles. Without
    # --no-loadscope-reorder xdist sorts the files by their number of tests instead,
    # which put these few-test, long files last.
    items.sort(key=lambda item: item.get_closest_marker("slow") is None)
