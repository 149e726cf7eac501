"""Meshes for MuJoCo: MuJoCo reads STL, OBJ and MSH only; any other mesh of a URDF (Collada ``.dae``, PLY, ...)
is converted once to binary STL with trimesh (Collada through pycollada) into a cache folder.

The cache folder is ``$WBC_MESH_CACHE``, else ``~/.cache/wbc/meshes``; a converted file is named by the SHA-1 of
the source path, size and modification time, so an edited mesh is converted again. The conversion keeps the
vertices in the file's own frame and units as trimesh reads them (the Collada scene's node transforms applied).
"""

from __future__ import annotations

import hashlib
import os
import warnings
from pathlib import Path

from wbc.exceptions import SimulationError

__all__ = ["MUJOCO_MESH_SUFFIXES", "mujoco_readable", "mesh_cache_dir"]

#: Mesh file suffixes MuJoCo reads itself.
MUJOCO_MESH_SUFFIXES = (".stl", ".obj", ".msh")


def mesh_cache_dir() -> Path:
    """Folder of the converted meshes (created when missing)."""
    path = Path(os.environ.get("WBC_MESH_CACHE", Path.home() / ".cache" / "wbc" / "meshes"))
    path.mkdir(parents=True, exist_ok=True)
    return path


def mujoco_readable(path: Path) -> Path:
    """A mesh file MuJoCo can read for ``path``: ``path`` itself (STL/OBJ/MSH), else its STL conversion.

    Raises:
        SimulationError: trimesh (or pycollada for ``.dae``) is not installed, cannot read the file, or the file
            has no triangles.
    """
    path = Path(path)
    if path.suffix.lower() in MUJOCO_MESH_SUFFIXES:
        return path
    stat = path.stat()
    key = hashlib.sha1(f"{path.resolve()}|{stat.st_size}|{stat.st_mtime_ns}".encode()).hexdigest()[:16]
    out = mesh_cache_dir() / f"{path.stem}-{key}.stl"
    if out.is_file():
        return out
    try:
        import trimesh
    except ImportError as exc:  # pragma: no cover - a dependency of wbc
        raise SimulationError(f"mesh {path} needs trimesh to be converted for MuJoCo: pip install trimesh "
                              f"pycollada") from exc
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            mesh = trimesh.load(str(path), force="mesh")
    except Exception as exc:  # trimesh raises many types for unreadable files
        raise SimulationError(f"cannot convert mesh {path} for MuJoCo with trimesh: {exc} (for .dae install "
                              f"pycollada; or set [mujoco] meshes = \"collision\" in the robot file)") from exc
    if not hasattr(mesh, "faces") or len(mesh.faces) == 0:
        raise SimulationError(f"mesh {path} has no triangles after conversion; replace it in the URDF")
    tmp = out.with_suffix(f".{os.getpid()}.tmp.stl")
    mesh.export(str(tmp), file_type="stl")
    tmp.replace(out)
    return out
