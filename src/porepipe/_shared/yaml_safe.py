"""YAML for scene files: safe, bounded and unambiguous.

PyYAML's ``safe_load`` lets a 1 KB file with nested aliases expand to gigabytes once it is validated or printed (the
"billion laughs"), keeps the last of two equal keys silently, and reads ``1e2`` as a string (YAML 1.1 wants a dot in a
float). :func:`load_yaml` refuses a file over :data:`MAX_BYTES`, a document whose expanded tree has more than
:data:`MAX_NODES` values (aliases counted every time they are used), and duplicate keys, each with a message naming the
file, and reads YAML 1.2 floats (``1e2``, ``-3E-1``) as numbers.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import yaml

from porepipe._shared.errors import PorepipeError

#: largest scene file read (a scene is a few KB; inline spheres or paths to files hold the bulk data)
MAX_BYTES = 4 * 2**20
#: most values in a document after alias expansion (the largest shipped scene has a few hundred)
MAX_NODES = 200_000

_FLOAT_1_2 = re.compile(r"^[-+]?(?:[0-9][0-9_]*)(?:\.[0-9_]*)?[eE][-+]?[0-9]+$")


class _BoundedLoader(yaml.SafeLoader):
    """SafeLoader that refuses duplicate mapping keys and reads exponent floats without a dot."""

    def construct_mapping(self, node, deep=False):
        if isinstance(node, yaml.MappingNode):
            self.flatten_mapping(node)
            seen: dict[Any, Any] = {}
            for key_node, _ in node.value:
                key = self.construct_object(key_node, deep=deep)
                try:
                    hash(key)
                except TypeError:
                    continue  # SafeLoader's own error follows
                if key in seen:
                    raise yaml.constructor.ConstructorError(
                        "while constructing a mapping",
                        node.start_mark,
                        f"duplicate key {key!r} (first at line {seen[key].start_mark.line + 1})",
                        key_node.start_mark,
                    )
                seen[key] = key_node
        return super().construct_mapping(node, deep=deep)


_BoundedLoader.add_implicit_resolver("tag:yaml.org,2002:float", _FLOAT_1_2, list("-+0123456789"))


def _count_nodes(value: Any, limit: int) -> int:
    """Number of values in the tree of ``value`` (shared sub-trees counted at every use), stopping past ``limit``."""
    count, stack = 0, [value]
    while stack and count <= limit:
        item = stack.pop()
        count += 1
        if isinstance(item, dict):
            stack.extend(item.keys())
            stack.extend(item.values())
        elif isinstance(item, (list, tuple)):
            stack.extend(item)
    return count


def load_yaml(path) -> Any:
    """Read one YAML document from ``path`` with the bounds of this module.

    Parameters
    ----------
    path : path-like
        The YAML file.

    Returns
    -------
    Any
        The document (dicts, lists, str, int, float, bool, None).

    Raises
    ------
    PorepipeError
        A file over :data:`MAX_BYTES`, invalid YAML, a duplicate key, or a tree of more than :data:`MAX_NODES` values.
    """
    path = Path(path)
    size = path.stat().st_size
    if size > MAX_BYTES:
        raise PorepipeError(
            f"{path}: {size} bytes, more than the {MAX_BYTES} a scene file may have; put bulk data "
            "(spheres, images) in files the scene names"
        )
    try:
        document = yaml.load(path.read_text(), Loader=_BoundedLoader)  # a SafeLoader subclass
    except yaml.YAMLError as err:
        text = " ".join(str(err).split())
        raise PorepipeError(f"{path}: not valid YAML: {text[:300]}") from None
    if _count_nodes(document, MAX_NODES) > MAX_NODES:
        raise PorepipeError(
            f"{path}: more than {MAX_NODES} values once its aliases are expanded (an alias bomb?); "
            "a scene needs far fewer"
        )
    return document
