"""Every shipped scene has a picture in the generated gallery: docs/hooks/generated.py puts docs/gallery/<scene>.png
with its caption into the page, the file is there, a small PNG (≤ 60 KB, 400 × 300 px as make_pictures.py draws
it), and docs/gallery/make_pictures.py knows how to remake it. Nothing is rendered here."""

import importlib.util
import json
import struct
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[3]
GALLERY = ROOT / "docs" / "gallery"
SCENES = sorted(p.stem for p in (ROOT / "config" / "scenes").glob("*.yaml"))


def _module(path: Path):
    spec = importlib.util.spec_from_file_location(path.stem, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _png_size(path: Path) -> tuple[int, int]:
    head = path.read_bytes()[:24]
    assert head[:8] == b"\x89PNG\r\n\x1a\n" and head[12:16] == b"IHDR", f"{path.name} is not a PNG"
    return struct.unpack(">II", head[16:24])


def test_the_generated_gallery_shows_every_shipped_scene_with_its_picture_and_caption():
    page = _module(ROOT / "docs" / "hooks" / "generated.py").scene_gallery()
    captions = json.loads((GALLERY / "captions.json").read_text())
    assert len(SCENES) >= 13
    for scene in SCENES:
        assert f"![{scene}](gallery/{scene}.png)" in page, f"no picture of {scene} in the gallery"
        assert captions[scene] and f"*{captions[scene]}*" in page, f"no caption for {scene}"


@pytest.fixture(scope="module")
def makers():
    return _module(GALLERY / "make_pictures.py").MAKERS


@pytest.mark.parametrize("scene", SCENES)
def test_each_picture_is_a_small_png_that_make_pictures_can_remake(scene, makers):
    path = GALLERY / f"{scene}.png"
    assert path.is_file(), f"{path} missing: python docs/gallery/make_pictures.py {scene}"
    assert path.stat().st_size <= 60_000
    assert _png_size(path) == (400, 300)
    assert scene in makers
