import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))  # tests/naive.py


def pytest_collection_modifyitems(items):
    """Tests marked ``slow`` (a minute or more on the 2-core machine) first, the rest in their usual order: on the
    README's two workers the long runs then start at once and overlap the many short ones, instead of running on
    alone at the end of the suite.
    """
    items.sort(key=lambda item: item.get_closest_marker("slow") is None)
