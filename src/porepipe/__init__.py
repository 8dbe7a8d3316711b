"""porepipe: digital models of granular porous rock, built and measured."""

import os

from porepipe._version import __version__ as __version__

# numba colours its error texts with colorama where colorama is installed (mkdocs-material pulls it in), and colorama
# then writes a terminal reset to stdout as the process exits: a stray escape after every command's output, which
# once landed inside a line another program parsed. Read by numba when it is first imported; a user's own value wins.
os.environ.setdefault("NUMBA_DISABLE_ERROR_MESSAGE_HIGHLIGHTING", "1")


def open_result(path):
    """Open any porepipe result file as one :class:`xarray.Dataset` (named dimensions, coordinates and units).

    Parameters
    ----------
    path : path-like
        A result file (``packing.h5``, ``grey_a2.h5``, ``binary_a2.h5``, ``minkowski_a1.h5``, ``sweep.h5`` …).

    Returns
    -------
    xarray.Dataset
        Root table, volumes (dims ``x_um``, ``y_um``, ``z_um``, µm) and named arrays, lazily loaded; provenance and
        cost as ``attrs``. See :func:`porepipe._shared.store.open_result`.
    """
    from porepipe._shared.store import open_result as _open_result  # here: `import porepipe` stays light

    return _open_result(path)
