"""MkDocs hook: fills the scene reference from the pydantic scene schema and the gallery from config/scenes.

``<!-- scene-reference -->`` in a page becomes one table per section of :class:`porepipe.scene.Scene` (key, type,
default, meaning), so the reference never drifts from the code; ``<!-- scene-gallery -->`` becomes one entry per
shipped scene, from the scene file's own leading comment and its analyses, with its picture and caption from
docs/gallery (``docs/gallery/make_pictures.py`` makes them).
"""

from __future__ import annotations

import enum
import json
import typing
from pathlib import Path

import yaml
from pydantic import BaseModel
from pydantic_core import PydanticUndefined

ROOT = Path(__file__).resolve().parents[2]
#: the gallery's pictures and captions.json, made by docs/gallery/make_pictures.py
GALLERY = ROOT / "docs" / "gallery"

#: wall time of a whole `porepipe run SCENE --cores N`, measured (see the README's table for the conditions)
MEASURED = {
    "mini": "58–69 s the first time on a fresh clone (numba compiles every kernel), 23 s with a warm cache; 2 cores, load ~1.7",
    "filled-packing-ci": "41 s (`--cores 1`, shared loaded 2-core machine, numba cache warm)",
    "rough-walls-ci": "35 s (`--cores 1`, shared loaded 2-core machine, numba cache warm)",
    "granular-box": "26 s (`--cores 1`, shared loaded 2-core machine, numba cache warm)",
    "mini-diffusion": "81 s (`--cores 1`, shared loaded 2-core machine, numba cache warm)",
    "image-to-model": "131 s (`--cores 1`, shared loaded 2-core machine, numba cache partly warm)",
    "granular-heap-ci": "30 s (`--cores 1`, shared loaded 2-core machine, numba cache partly warm)",
    "granular-silo-ci": "66 s (`--cores 1`, shared loaded 2-core machine, numba cache partly warm)",
    "granular-silo-stepped-ci": "granular stage alone: 189 s wall, 36 s CPU (one thread, shared 2-core machine at load ~7)",
    "granular-silo-hopper-ci": "granular stage alone: 208 s wall, 38 s CPU (one thread, shared 2-core machine at load ~7)",
    "granular-silo-parabolic-ci": "granular stage alone: 76 s wall, 24 s CPU (one thread, shared 2-core machine at load ~7)",
    "granular-silo-hopper-mu07": "granular stage alone: 131 s wall, 35 s CPU (one thread, shared 2-core machine at load ~7)",
    "granular-silo-parabolic-mu07": "granular stage alone: 114 s wall, 24 s CPU (one thread, shared 2-core machine at load ~7)",
    "granular-silo-hopper": "granular stage alone: 27.7 min wall, 627 s CPU, 0.43 GB (one thread, shared 2-core machine at load ~4.5)",
    "granular-silo-parabolic": "granular stage alone: 24.5 min wall, 576 s CPU, 0.30 GB (one thread, shared 2-core machine at load ~4.5)",
    "granular-silo-stepped": "granular stage alone: 66 min wall, 1998 s CPU, 0.44 GB (one thread, shared 2-core machine at load ~4.5)",
    "granular-silo-hopper-mu07-full": "granular stage alone: 18.4 min wall, 570 s CPU, 0.30 GB (one thread, shared 2-core machine at load ~3)",
    "granular-silo-parabolic-mu07-full": "granular stage alone: 18.2 min wall, 556 s CPU, 0.30 GB (one thread, shared 2-core machine at load ~3)",
    "granular-heap-poured-thesis": "granular stage alone, per seed: 7-8 min wall, ~420 s CPU, 0.29 GB (one thread, shared 2-core machine at load ~2-4)",
    "granular-heap-unload-ci": "granular stage alone: 152 s wall, 25 s CPU (one thread, shared 2-core machine at load ~7)",
    "filled-packing": "3.1 min and 1.1 GB for `porepipe pack` (2 cores)",
    "rough-walls": "6.6 min and 1.3 GB for `porepipe pack` (2 cores)",
}


def _type_name(annotation) -> str:
    if isinstance(annotation, type) and issubclass(annotation, enum.Enum):
        return " \\| ".join(f"`{m.value}`" for m in annotation)
    if isinstance(annotation, type):
        return annotation.__name__
    origin, args = typing.get_origin(annotation), typing.get_args(annotation)
    if origin is typing.Annotated:
        return _type_name(args[0])
    if origin in (typing.Union, getattr(__import__("types"), "UnionType", None)):
        return " or ".join(_type_name(a) for a in args)
    if origin in (list, tuple, dict):
        inner = ", ".join("…" if a is Ellipsis else _type_name(a) for a in args)
        return f"{origin.__name__}[{inner}]"
    if origin is typing.Literal:
        return " \\| ".join(f"`{a}`" for a in args)
    return str(annotation).replace("typing.", "")


def _default(field) -> str:
    if field.default_factory is not None:
        try:
            value = field.default_factory()
        except TypeError:
            return "(computed)"
    elif field.default is PydanticUndefined:
        return "**required**"
    else:
        value = field.default
    if isinstance(value, BaseModel):
        return "(section defaults)"
    if isinstance(value, enum.Enum):
        value = value.value
    return f"`{value!r}`".replace("|", "\\|")


def _models(annotation) -> list[type[BaseModel]]:
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return [annotation]
    return [m for a in typing.get_args(annotation) for m in _models(a)]


def _tables(model: type[BaseModel], path: str, seen: set) -> list[str]:
    lines = [f"### `{path}`" if path else "### top level", ""]
    doc = (model.__doc__ or "").strip().split("\n\n")[0].replace("\n", " ")
    if doc:
        lines += [doc, ""]
    lines += ["| key | type | default | meaning |", "|---|---|---|---|"]
    nested = []
    for name, field in model.model_fields.items():
        meaning = (field.description or "").replace("|", "\\|").replace("\n", " ")
        lines.append(f"| `{name}` | {_type_name(field.annotation)} | {_default(field)} | {meaning} |")
        for sub in _models(field.annotation):
            if sub not in seen:
                seen.add(sub)
                nested.append((sub, f"{path}.{name}" if path else name))
    lines.append("")
    for sub, sub_path in nested:
        lines += _tables(sub, sub_path, seen)
    return lines


def scene_reference() -> str:
    """Markdown tables of every section and key of the scene schema."""
    from porepipe.scene import Scene

    return "\n".join(_tables(Scene, "", {Scene}))


def _leading_comment(text: str) -> str:
    lines = []
    for line in text.splitlines():
        if not line.startswith("#"):
            break
        lines.append(line.lstrip("# ").rstrip())
    return " ".join(lines)


def scene_gallery() -> str:
    """One entry per shipped scene: what it does (its own comment), its analyses, its measured cost and its picture."""
    out = []
    captions = (
        json.loads((GALLERY / "captions.json").read_text()) if (GALLERY / "captions.json").is_file() else {}
    )
    for path in sorted((ROOT / "config" / "scenes").glob("*.yaml")):
        text = path.read_text()
        raw = yaml.safe_load(text)
        analyses = ", ".join(raw.get("analyses", ["estimate"]))
        size = raw.get("domain", {}).get("size_um")
        box = f"box {' × '.join(f'{s:g}' for s in size)} µm; " if size else ""
        resolutions = raw.get("resolutions_um")
        res = f"resolutions {', '.join(f'{a:g}' for a in resolutions)} µm; " if resolutions else ""
        out += [
            f"## {raw['name']}",
            "",
            _leading_comment(text),
            "",
            f"- **Runs**: `porepipe run config/scenes/{path.name} --cores 2`",
            f"- **Asks for**: {box}{res}analyses {analyses}",
            f"- **Measured cost**: {MEASURED.get(raw['name'], 'not measured yet')}",
            "",
            *_picture(path.stem, captions),
        ]
    return "\n".join(out)


def _picture(stem: str, captions: dict) -> list[str]:
    """The scene's picture from docs/gallery (made by docs/gallery/make_pictures.py) with its caption."""
    if stem not in captions or not (GALLERY / f"{stem}.png").is_file():
        return ["*No picture yet: run `python docs/gallery/make_pictures.py " + stem + "`.*", ""]
    return [f"![{stem}](gallery/{stem}.png)", "", f"*{captions[stem]}*", ""]


def on_page_markdown(markdown, page, config, files):
    """MkDocs event: replace the markers with the generated text."""
    if "<!-- scene-reference -->" in markdown:
        markdown = markdown.replace("<!-- scene-reference -->", scene_reference())
    if "<!-- scene-gallery -->" in markdown:
        markdown = markdown.replace("<!-- scene-gallery -->", scene_gallery())
    return markdown
