"""Where the workflow files are: inside the installed package, or in the repository of an editable install."""

from __future__ import annotations

from pathlib import Path

from porepipe._shared.errors import PorepipeError

#: the package folder (src/porepipe in the repository, site-packages/porepipe when installed)
PACKAGE_DIR = Path(__file__).resolve().parents[1]


def workflow_root(package_dir: Path = PACKAGE_DIR) -> Path:
    """The folder that holds the Snakefile, ``workflow/`` and ``config/``.

    Parameters
    ----------
    package_dir : Path
        The ``porepipe`` package folder (default: this installation's).

    Returns
    -------
    Path
        ``package_dir/_workflow`` when porepipe was installed with ``pip install .`` (setup.py copies the workflow
        there), else the repository root two levels above the package (``pip install -e .`` from a clone).

    Raises
    ------
    PorepipeError
        If neither place holds a Snakefile.
    """
    candidates = [package_dir / "_workflow", package_dir.parents[1]]
    for root in candidates:
        if (root / "Snakefile").is_file() and (root / "workflow" / "rules").is_dir():
            return root
    raise PorepipeError(
        f"porepipe's Snakefile is in none of {', '.join(str(c) for c in candidates)}; "
        "reinstall porepipe (pip install . or pip install -e . from its repository)"
    )


def scene_path(name_or_path: str | Path) -> Path:
    """A scene file given by path, or by the name of a scene shipped with porepipe (``mini``, ``granular-box`` …).

    Parameters
    ----------
    name_or_path : str or Path
        A path to a YAML file, or a shipped scene's name (the file name without ``.yaml``).

    Returns
    -------
    Path
        The path as given when it names a file (or does not look like a bare name), else the shipped scene's file.
    """
    path = Path(name_or_path)
    if path.is_file() or path.suffix or len(path.parts) > 1:
        return path
    shipped = workflow_root() / "config" / "scenes" / f"{path.name}.yaml"
    return shipped if shipped.is_file() else path
