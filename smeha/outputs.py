"""Files the package writes for the user: whole or not at all.

Every output file (a plot, a record, a table, a measurement file) is written to a
temporary file beside its target and renamed onto it once complete
(:func:`replacing`): an error or Ctrl-C halfway leaves the previous file, or none, and
no half-written one. The rename is atomic on one file system (``os.replace``), which
the temporary file beside the target guarantees.
"""
from __future__ import annotations

import contextlib
import os
import tempfile
from pathlib import Path

__all__ = ["replacing", "save_figure"]


@contextlib.contextmanager
def replacing(path):
    """A context giving a temporary path beside ``path``, renamed onto ``path`` on success.

    The temporary file keeps the target's suffix (matplotlib picks the format from it) and
    is removed when the block raises, KeyboardInterrupt included.

    Parameters
    ----------
    path : str or Path
        The file to write; its folder must exist.

    Yields
    ------
    Path
        Where to write.
    """
    path = Path(path)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.stem}.", suffix=path.suffix)
    os.close(fd)
    tmp = Path(tmp)
    os.chmod(tmp, 0o666 & ~_umask())  # the permissions a plain open() would give
    try:
        yield tmp
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


def _umask() -> int:
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def save_figure(fig, path, **kwargs) -> Path:
    """``fig.savefig(path, **kwargs)`` through :func:`replacing`; the figure is closed."""
    import matplotlib.pyplot as plt

    try:
        with replacing(path) as tmp:
            fig.savefig(tmp, **kwargs)
    finally:
        plt.close(fig)
    return Path(path)
