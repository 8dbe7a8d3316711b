"""Make the gallery's pictures: one small PNG per scene in config/scenes, and captions.json that says how each was made.

Scenes that run in seconds are run for real (their first stages, at the scene's own size, through the ``porepipe``
command) and the result is drawn; heavy full-size scenes are drawn from what the scene file itself defines, without
running them, and their caption says so. Rerun after changing a scene::

    .venv/bin/python docs/gallery/make_pictures.py            # every scene (a few minutes on 2 cores)
    .venv/bin/python docs/gallery/make_pictures.py mini       # only the named scenes

The pictures are 400 × 300 px (matplotlib Agg); docs/hooks/generated.py puts each one, with its caption, into the
gallery.
"""

from __future__ import annotations

import json
import subprocess
import sys
import tempfile
from pathlib import Path

import h5py
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
import yaml
from matplotlib.collections import PolyCollection

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
SCENES = ROOT / "config" / "scenes"
CAPTIONS = HERE / "captions.json"
PIPE = [str(Path(sys.executable).with_name("porepipe"))]


def _scene(name: str) -> dict:
    return yaml.safe_load((SCENES / f"{name}.yaml").read_text())


def _porepipe(*args) -> None:
    subprocess.run([*PIPE, *map(str, args)], check=True, cwd=ROOT, stdout=subprocess.DEVNULL)


def _figure():
    fig, ax = plt.subplots(figsize=(4, 3), dpi=100)
    return fig, ax


def _save(fig, name: str) -> None:
    fig.tight_layout()
    fig.savefig(HERE / f"{name}.png", dpi=100)
    plt.close(fig)


def _grey_slice(ax, grey: np.ndarray, voxel_um: float, title: str) -> None:
    k = grey.shape[2] // 2
    n, m = grey.shape[:2]
    im = ax.imshow(
        grey[:, :, k].T,
        origin="lower",
        cmap="gray_r",
        vmin=0,
        vmax=216,
        extent=(0, n * voxel_um, 0, m * voxel_um),
    )
    ax.set_xlabel("x (µm)")
    ax.set_ylabel("y (µm)")
    ax.set_title(title, fontsize=9)
    ax.figure.colorbar(im, ax=ax, label="grey (0 pore, 216 matrix)", fraction=0.046)


# -- scenes that run: pack, then voxelise at the scene's finest resolution -----------------------------------------
def packed(name: str) -> str:
    """Pack the scene's spheres (its own pack stage) and draw the mid-plane of its grey volume at the finest a."""
    from porepipe.voxelize import voxelize

    raw = _scene(name)
    a = min(raw["resolutions_um"])
    with tempfile.TemporaryDirectory() as tmp:
        _porepipe("pack", SCENES / f"{name}.yaml", "-o", Path(tmp) / "packing.h5", "--threads", 2)
        with h5py.File(Path(tmp) / "packing.h5") as f:
            centres, radii = f["centres_um"][...], f["radii_um"][...]
    box = raw["domain"]["size_um"]
    grey = voxelize(centres, radii, box_um=box, voxel_um=a)
    fig, ax = _figure()
    _grey_slice(ax, grey, a, f"{name}: grey volume at a = {a:g} µm, z = {box[2] / 2:g} µm")
    _save(fig, name)
    return (
        f"Run for this picture: the scene's own packing ({len(radii)} spheres, `porepipe pack`), voxelised at a = {a:g} µm; the grey values of the mid-plane z = {box[2] / 2:g} µm "
        "(0 = pore, 216 = matrix)."
    )


def granular(name: str) -> str:
    """Run the scene's 2-D DEM to its end and draw the settled polygons of the last frame."""
    from porepipe.granular import frame_particles, read_granular

    with tempfile.TemporaryDirectory() as tmp:
        _porepipe(
            "granular", SCENES / f"{name}.yaml", "-o", Path(tmp) / "granular.h5", "--threads", 2, "--quiet"
        )
        tables = read_granular(Path(tmp) / "granular.h5")
    last = frame_particles(tables, -1)
    t_end = float(tables["frames"].time_s.values[-1])
    walls = tables["frames"]["wall_vertices_m"].values
    polys = [p * 100 for p, on in zip(last["polygons"], last["active"], strict=True) if on]
    lo, hi = np.min([p.min(axis=0) for p in polys], axis=0), np.max([p.max(axis=0) for p in polys], axis=0)
    tall = hi[1] - lo[1] > 3 * (hi[0] - lo[0])  # a silo: show the whole column and its bottom enlarged
    fig, axes = plt.subplots(1, 2 if tall else 1, figsize=(4, 3), dpi=100, squeeze=False)
    for ax in axes[0]:
        ax.add_collection(PolyCollection(polys, facecolors="#c8a165", edgecolors="#5a4020", linewidths=0.3))
        for w in walls:
            w = w[~np.isnan(w[:, 0])] * 100
            ax.fill(w[:, 0], w[:, 1], color="0.4")
        ax.autoscale_view()
        ax.set_aspect("equal")
        ax.set_xlabel("x (cm)")
    axes[0][0].set_ylabel("y (cm)")
    zoom = ""
    if tall:
        width = hi[0] - lo[0]
        axes[0][1].set_xlim(lo[0] - 0.1 * width, hi[0] + 0.1 * width)
        axes[0][1].set_ylim(lo[1] - 0.1 * width, lo[1] + 1.2 * width)
        axes[0][1].set_title("bottom, enlarged", fontsize=8)
        axes[0][0].locator_params(axis="x", nbins=2)
        zoom = "; right: the bottom of the column enlarged"
    fig.suptitle(f"{name}: {len(polys)} polygons at t = {t_end:.3g} s", fontsize=9)
    _save(fig, name)
    return (
        "Run for this picture: the scene's whole 2-D DEM (`porepipe granular`); the polygons of the last frame "
        f"(t = {t_end:.3g} s) and the walls in grey{zoom}."
    )


def _geometry_words(geometry: dict) -> str:
    """``{kind: square, a: 30, length: 600}`` as "square, a 30, length 600" (µm where the key says so, else voxels)."""
    sizes = ", ".join(
        f"{k.removesuffix('_um').replace('_', ' ')} {v:g}{' µm' if k.endswith('_um') else ''}"
        for k, v in geometry.items()
        if k != "kind"
    )
    in_voxels = not any(k.endswith("_um") for k in geometry)
    return f"{geometry['kind']}, {sizes}" + (" voxels" if in_voxels else "")


def capillary(name: str) -> str:
    """Write the scene's synthetic capillary at its finest a and draw a section through its axis."""
    from porepipe._shared.store import read_binary_volume

    raw = _scene(name)
    a = min(raw["resolutions_um"])
    with tempfile.TemporaryDirectory() as tmp:
        _porepipe(
            "diffusion-capillary", "--scene", SCENES / f"{name}.yaml", "--a", a, "-o", Path(tmp) / "b.h5"
        )
        pore, meta = read_binary_volume(Path(tmp) / "b.h5")
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(4, 3), dpi=100, width_ratios=[1, 1])
    n = pore.shape
    ax.imshow(
        pore[:, n[1] // 2, :],
        origin="lower",
        cmap="Blues",
        vmin=0,
        vmax=1.4,
        extent=(0, n[2] * a, 0, n[0] * a),
    )
    ax.set_title("section y = mid", fontsize=8)
    ax.set_xlabel("z (µm)")
    ax.set_ylabel("x (µm)")
    bx.imshow(
        pore[:, :, n[2] // 2].T,
        origin="lower",
        cmap="Blues",
        vmin=0,
        vmax=1.4,
        extent=(0, n[0] * a, 0, n[1] * a),
    )
    bx.set_title("section z = mid", fontsize=8)
    bx.set_xlabel("x (µm)")
    fig.suptitle(f"{name}: pore voxels (blue) at a = {a:g} µm", fontsize=9)
    _save(fig, name)
    g = raw["diffusion"]["geometry"]
    return (
        f"Run for this picture: the scene's capillary ({_geometry_words(g)}) "
        f"as `porepipe diffusion-capillary` voxelises it at a = {a:g} µm, {int(pore.sum())} pore voxels; sections "
        "along and across the axis (the diffusion itself is not run here)."
    )


def image(name: str) -> str:
    """Draw the mid-plane of the scene's own input image (the synthetic µ-CT TIFF it ships with)."""
    import tifffile

    raw = _scene(name)
    path = ROOT / "config" / "scenes" / "data" / "image-to-model.tif"
    img = tifffile.imread(path)
    a = raw["resolutions_um"][0]
    fig, ax = _figure()
    k = img.shape[0] // 2
    im = ax.imshow(img[k], origin="lower", cmap="gray", extent=(0, img.shape[2] * a, 0, img.shape[1] * a))
    fig.colorbar(im, ax=ax, label="8-bit grey", fraction=0.046)
    ax.set_xlabel("µm")
    ax.set_ylabel("µm")
    ax.set_title(f"{name}: input image, slice {k} of {img.shape[0]}", fontsize=9)
    _save(fig, name)
    return (
        f"The scene's input: slice {k} of the {' × '.join(map(str, img.shape))}-voxel synthetic µ-CT image "
        f"`config/scenes/data/{path.name}` ({a:g} µm voxels) that the scene's `acquire` stage reads; nothing is run."
    )


# -- heavy scenes: drawn from the scene file, not run -----------------------------------------------------------------
def _radius_pdf(spec: dict, r: np.ndarray) -> np.ndarray:
    lo, hi = spec["min_um"], spec["max_um"]
    inside = (r >= lo) & (r <= hi)
    if spec["dist"] == "exponential":
        al = spec["alpha_per_um"]
        return np.where(inside, al * np.exp(-al * (r - lo)) / (1 - np.exp(-al * (hi - lo))), 0.0)
    return np.where(inside, 1.0 / (hi - lo), 0.0)


def radii(name: str) -> str:
    """Expected number of spheres per µm of radius of each sphere type, from the scene's radius distributions."""
    raw = _scene(name)
    fig, ax = _figure()
    for t in raw["packing"]["types"]:
        spec = t["radius_um"]
        r = np.linspace(spec["min_um"] * 0.9, spec["max_um"] * 1.05, 2000)
        ax.plot(r, t["count"] * _radius_pdf(spec, r), label=f"{t['name']}: {t['count']:,} spheres")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_ylim(bottom=1e-1)
    ax.set_xlabel("radius r (µm)")
    ax.set_ylabel("spheres per µm of r")
    ax.legend(fontsize=7, loc="upper right")
    size = raw["domain"]["size_um"]
    ax.set_title(f"{name}: inserted radii, box {size[0]:g} µm (not run)", fontsize=9)
    _save(fig, name)
    n = sum(t["count"] for t in raw["packing"]["types"])
    return (
        f"Not run for this picture (the full-size packing of {n:,} spheres takes minutes and GBs): the radius "
        "distributions the scene file asks for, drawn from its `packing.types` (count × probability density; "
        "the radius protocol and the deletion of unconverged spheres change them during the run)."
    )


#: silo scenes drawn without a run: (cost of the full run, where the fill ends)
SILO_NOTES = {
    "granular-silo": ("~40 min on one core", "the silo fills from the top to about 36 cm"),
    "granular-silo-stepped": ("~33 min CPU", "the outer sources start when the fill reaches the step"),
    "granular-silo-hopper": ("~10 min CPU", "a source starts when the fill has widened past it"),
    "granular-silo-parabolic": ("~10 min CPU", "a source starts when the fill has widened past it"),
    "granular-silo-hopper-mu07-full": ("~10 min CPU", "as granular-silo-hopper, with grain friction 0.7"),
    "granular-silo-parabolic-mu07-full": (
        "~10 min CPU",
        "as granular-silo-parabolic, with grain friction 0.7",
    ),
    "granular-heap-poured-thesis": ("~7 min CPU a seed", "one point source pours the heap from 18 cm"),
}


def silo(name: str) -> str:
    """The silo and where its drop sources insert the grains, as the simulation places them (no step)."""
    from porepipe.granular import Settings, Simulation, silo_wall_slabs

    raw = _scene(name)
    settings = Settings.model_validate(raw["granular"])
    sim = Simulation(settings, seed=raw.get("seed", 0))
    pos = sim.position[: sim.n_mob]
    fig, ax = _figure()
    if settings.silo is not None:
        for _, v in silo_wall_slabs(settings.silo):
            ax.fill(v[:, 0] * 100, v[:, 1] * 100, color="0.3", lw=0)
    else:
        (x0, y0), (x1, y1) = settings.box.lower_m, settings.box.upper_m
        ax.plot(
            [x0 * 100, x0 * 100, x1 * 100, x1 * 100],
            [y1 * 100, y0 * 100, y0 * 100, y1 * 100],
            color="0.3",
            lw=2,
        )
    ax.scatter(pos[:, 0] * 100, pos[:, 1] * 100, s=0.2, color="#8a6a3a", linewidths=0)
    ax.set_aspect("equal")
    ax.set_xlabel("x (cm)")
    ax.set_ylabel("y (cm)")
    ax.set_title(f"{name}: insertion points of {sim.n_mob:,} grains (not run)", fontsize=9)
    _save(fig, name)
    cost, fill = SILO_NOTES[name]
    n_src = len(settings.drop_sources)
    rising = any(src.rise_m_s for src in settings.drop_sources)
    where = (
        f"the sources rise with the fill, so the dots form {n_src} rising lines"
        if rising
        else f"the {n_src} source(s) stay put, so the dots stack at one height each"
    )
    return (
        f"Not run for this picture ({cost}): the walls and where the scene's drop sources insert "
        f"its {sim.n_mob:,} polygons (one dot per grain, at its insertion height: {where}); {fill}."
    )


def grains(name: str) -> str:
    """Circles where the scene's spheres (its ``spheres.xyzr`` file) cut the mid-plane (before any decoration)."""
    raw = _scene(name)
    source = raw["spheres"]["xyzr"]
    xyzr = np.loadtxt(SCENES / source)
    size = raw["domain"]["size_um"]
    z = size[2] / 2
    fig, ax = _figure()
    images = (-1, 0, 1) if raw["domain"].get("periodic", True) else (0,)
    for dx, dy, dz in [(dx, dy, dz) for dx in images for dy in images for dz in images]:
        d = xyzr[:, 2] + dz * size[2] - z
        cut = np.abs(d) < xyzr[:, 3]
        cut_r = np.sqrt(xyzr[cut, 3] ** 2 - d[cut] ** 2)
        for x, y, r in zip(xyzr[cut, 0] + dx * size[0], xyzr[cut, 1] + dy * size[1], cut_r, strict=True):
            ax.add_patch(plt.Circle((x, y), r, color="#b9a27c", lw=0))
    ax.set_xlim(0, size[0])
    ax.set_ylim(0, size[1])
    ax.set_aspect("equal")
    ax.set_xlabel("x (µm)")
    ax.set_ylabel("y (µm)")
    ax.set_title(f"{name}: {len(xyzr)} spheres cut at z = {z:g} µm", fontsize=9)
    _save(fig, name)
    caption = (
        f"Not run for this picture: where the scene's {len(xyzr)} spheres (`config/scenes/{source}`) cut the "
        f"mid-plane z = {z:g} µm."
    )
    if "decoration" in raw:
        caption += " The run replaces each sphere by a decorated quartz grain of equal volume, so the real grains are faceted, not round."
    return caption


#: how each shipped scene gets its picture
MAKERS = {
    "mini": packed,
    "mini-diffusion": packed,
    "filled-packing-ci": packed,
    "rough-walls-ci": packed,
    "granular-box": granular,
    "granular-heap-ci": granular,
    "granular-heap-poured": granular,
    "granular-heap-layered": granular,
    "granular-heap-layered-ci": granular,
    "granular-heap-13gons": granular,
    "granular-heap-unload-ci": granular,
    "granular-heap-cohesive-ci": granular,
    "granular-heap-dip-ci": granular,
    "granular-heap-poured-ensemble": granular,
    "granular-heap-layered-ensemble": granular,
    "granular-silo-ci": granular,
    "granular-silo-mu05": granular,
    "granular-silo-mu07": granular,
    "granular-silo-stepped-ci": granular,
    "granular-silo-hopper-ci": granular,
    "granular-silo-parabolic-ci": granular,
    "granular-silo-hopper-mu07": granular,
    "granular-silo-parabolic-mu07": granular,
    "knudsen-capillary-ci": capillary,
    "knudsen-length-series": capillary,
    "knudsen-length-series-ci": capillary,
    "mesopore-a": capillary,
    "mesopore-a-ci": capillary,
    "mesopore-b": capillary,
    "mesopore-b-ci": capillary,
    "mesopore-c": capillary,
    "mesopore-c-ci": capillary,
    "mesopore-a-thesis": capillary,
    "mesopore-b-thesis": capillary,
    "mesopore-c-thesis": capillary,
    "surface-reactions-ci": capillary,
    "image-to-model": image,
    "filled-packing": radii,
    "rough-walls": radii,
    "granular-silo": silo,
    "granular-silo-stepped": silo,
    "granular-silo-hopper": silo,
    "granular-silo-hopper-mu07-full": silo,
    "granular-silo-parabolic-mu07-full": silo,
    "granular-heap-poured-thesis": silo,
    "granular-silo-parabolic": silo,
    "fontainebleau-like": grains,
    "thesis-5.6.1-ci": packed,
    "thesis-5.6.1-pp-ci": packed,
    "thesis-5.6.1": radii,
    "thesis-5.6.1-pp": radii,
    "thesis-5.6.1-sub": grains,
    "thesis-5.6.1-pp-sub": grains,
    "thesis-5.6.2": radii,
    "bentheimer-8.3-ci": packed,
    "bentheimer-8.3": radii,
}


def main(names: list[str]) -> None:
    """Make the pictures of ``names`` (all shipped scenes if empty) and update captions.json."""
    shipped = sorted(p.stem for p in SCENES.glob("*.yaml"))
    missing = sorted(set(shipped) - set(MAKERS))
    if missing:
        raise SystemExit(f"no picture maker for scene(s) {', '.join(missing)}: add them to MAKERS")
    captions = json.loads(CAPTIONS.read_text()) if CAPTIONS.exists() else {}
    for name in names or shipped:
        print(f"{name} …", flush=True)
        captions[name] = MAKERS[name](name)
        CAPTIONS.write_text(json.dumps(dict(sorted(captions.items())), indent=1, ensure_ascii=False) + "\n")


if __name__ == "__main__":
    main(sys.argv[1:])
