"""Meshes given as arrays in a scene dict: ``{"mesh": Mesh}`` or ``{"mesh": {"vertices": V,
"faces": F}}`` become an OBJ file in a cache directory, named by the hash of its content, which
the scene then names as ``mesh.obj`` (what a scene file would do). The file is written by the
library's OBJ writer (``Mesh.save_obj``: shortest round-trip decimals, so the positions are
exact); the same mesh always gives the same file, so a sweep's provenance (the content of every
file a run reads) sees the mesh itself.

The cache directory is ``$THINSHELL_CACHE_DIR``, else ``$XDG_CACHE_HOME/thinshell`` (default
``~/.cache/thinshell``), subfolder ``meshes``.
"""

from __future__ import annotations

import hashlib
import os
import tempfile
from pathlib import Path
from typing import Any, Mapping


def cache_dir() -> Path:
    """Where meshes given as arrays are written."""
    base = os.environ.get("THINSHELL_CACHE_DIR")
    if base:
        return Path(base) / "meshes"
    xdg = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(xdg) / "thinshell" / "meshes"


def mesh_file(mesh: Any) -> Path:
    """The OBJ file of ``mesh`` (a :class:`thinshell.Mesh`), written if not there yet."""
    d = cache_dir()
    d.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=d, prefix=".mesh-", suffix=".obj")
    os.close(fd)
    try:
        mesh.save_obj(tmp)
        digest = hashlib.sha256(Path(tmp).read_bytes()).hexdigest()[:24]
        path = d / f"mesh-{digest}.obj"
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise
    return path.resolve()


def mesh_spec(value: Any) -> dict[str, Any]:
    """The ``[mesh]`` table for a mesh given in a scene dict."""
    from ._thinshell import Mesh

    if isinstance(value, Mesh):
        mesh = value
    elif isinstance(value, Mapping):
        extra = sorted(set(value) - {"vertices", "faces"})
        if extra:
            raise TypeError(
                f"scene `mesh`: a mesh given as arrays takes only `vertices` and `faces`, not {extra}"
            )
        if "vertices" not in value or "faces" not in value:
            raise TypeError("scene `mesh`: a mesh given as arrays needs both `vertices` (n x 3) and `faces` (m x 3)")
        mesh = Mesh(value["vertices"], value["faces"])
    else:
        raise TypeError(f"scene `mesh`: expected a table, a thinshell.Mesh or {{'vertices': V, 'faces': F}}, not {type(value).__name__}")
    return {"obj": str(mesh_file(mesh))}
