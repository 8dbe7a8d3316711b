"""Ship the workflow inside the package: ``pip install .`` copies the Snakefile, ``workflow/`` and ``config/`` to
``porepipe/_workflow/`` so that an installed ``porepipe run`` finds its rules without the repository.

An editable install (``pip install -e .``) copies nothing: ``porepipe._shared.resources.workflow_root`` then finds
the repository's own Snakefile. Everything else about the package is declared in pyproject.toml.
"""

import shutil
from pathlib import Path

from setuptools import setup
from setuptools.command.build_py import build_py

HERE = Path(__file__).resolve().parent
#: what `porepipe run` needs beside the code, relative to the repository root
WORKFLOW_FILES = ["Snakefile", "workflow", "config"]


def copy_workflow(root: Path, target: Path) -> None:
    """Copy the Snakefile, ``workflow/`` and ``config/`` of ``root`` into ``target`` (created; old copy replaced)."""
    if target.exists():
        shutil.rmtree(target)
    target.mkdir(parents=True)
    for name in WORKFLOW_FILES:
        source = root / name
        if source.is_dir():
            shutil.copytree(source, target / name, ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
        else:
            shutil.copy2(source, target / name)


class BuildPyWithWorkflow(build_py):
    """``build_py`` that also puts the workflow into ``porepipe/_workflow`` (not in editable mode)."""

    def run(self):
        """Build the package as usual, then copy the workflow beside it."""
        super().run()
        if not getattr(self, "editable_mode", False):
            copy_workflow(HERE, Path(self.build_lib, "porepipe", "_workflow"))


setup(cmdclass={"build_py": BuildPyWithWorkflow})
