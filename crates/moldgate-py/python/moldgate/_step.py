"""STEP and IGES files tessellated by gmsh (OpenCASCADE inside), the ``step`` extra.

gmsh keeps one global model, so calls are serialised by a lock; each call starts and
ends its own gmsh session.
"""

from __future__ import annotations

import math
import os
import stat
import threading

import numpy as np

from ._moldgate import LoadError, OptionsError, Part

_LOCK = threading.Lock()

#: Triangles per full turn of a curved face (gmsh's Mesh.MeshSizeFromCurvature).
TRIANGLES_PER_TURN = 24

#: Default largest triangle edge as a fraction of the part's diagonal.
DEFAULT_SIZE_FRACTION = 1.0 / 50.0


def _kind(mode: int) -> str:
    """What a file that is not a regular file is, as the library's messages say it."""
    for test, kind in (
        (stat.S_ISDIR, "a folder"),
        (stat.S_ISFIFO, "a FIFO"),
        (stat.S_ISCHR, "a character device"),
        (stat.S_ISBLK, "a block device"),
        (stat.S_ISSOCK, "a socket"),
    ):
        if test(mode):
            return kind
    return "not a regular file"


def _gmsh(path: str):
    try:
        import gmsh  # noqa: PLC0415
    except ImportError:
        raise LoadError(
            f'{path}: reading STEP and IGES files needs gmsh: pip install "moldgate[step]" '
            '(from a checkout: pip install "./crates/moldgate-py[step]")'
        ) from None
    return gmsh


def tessellate(path: str, tolerance_mm: float | None = None):
    """The surface of a STEP or IGES file as (vertices in mm, triangles), faces sewn
    into shells, triangles as gmsh orients them (outward on a solid)."""
    if tolerance_mm is not None and not (
        isinstance(tolerance_mm, (int, float)) and math.isfinite(tolerance_mm) and tolerance_mm > 0
    ):
        raise OptionsError(f"step_tolerance_mm must be a positive number, got {tolerance_mm!r}")
    try:
        mode = os.stat(path).st_mode
    except OSError as e:
        raise LoadError(f"{path}: cannot open: {e.strerror or e}") from None
    if not stat.S_ISREG(mode):
        # A FIFO or a device would block the read or never end it.
        raise LoadError(f"{path}: is {_kind(mode)}, not a mesh file")
    try:
        with open(path, "rb"):
            pass
    except OSError as e:
        raise LoadError(f"{path}: cannot open: {e.strerror or e}") from None
    gmsh = _gmsh(path)
    with _LOCK:
        try:
            # gmsh sets a SIGINT handler when interruptible, which Python allows in the main
            # thread only: from any other thread the session runs without one.
            gmsh.initialize(
                readConfigFiles=False,
                interruptible=threading.current_thread() is threading.main_thread(),
            )
            gmsh.option.setNumber("General.Terminal", 0)
            gmsh.option.setString("Geometry.OCCTargetUnit", "MM")
            # IGES (and some STEP) files hold loose faces: sew them into shells and solids
            # so that their edges are shared.
            gmsh.option.setNumber("Geometry.OCCSewFaces", 1)
            gmsh.option.setNumber("Geometry.OCCMakeSolids", 1)
            try:
                gmsh.open(path)
            except Exception as e:  # gmsh raises a plain Exception with its last error
                raise LoadError(f"{path}: gmsh cannot read it: {e}") from None
            surfaces = gmsh.model.getEntities(2)
            if not surfaces:
                raise LoadError(f"{path}: gmsh read no surface from it (not a STEP or IGES model?)")
            x0, y0, z0, x1, y1, z1 = gmsh.model.getBoundingBox(-1, -1)
            diagonal = math.dist((x0, y0, z0), (x1, y1, z1))
            size = tolerance_mm if tolerance_mm is not None else diagonal * DEFAULT_SIZE_FRACTION
            gmsh.option.setNumber("Mesh.MeshSizeMax", size)
            gmsh.option.setNumber("Mesh.MeshSizeMin", 0.0)
            gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", TRIANGLES_PER_TURN)
            try:
                gmsh.model.mesh.generate(2)
            except Exception as e:
                raise LoadError(f"{path}: gmsh cannot tessellate it: {e}") from None
            node_tags, coords, _ = gmsh.model.mesh.getNodes()
            node_tags = np.asarray(node_tags, dtype=np.int64)
            coords = np.asarray(coords, dtype=np.float64).reshape(-1, 3)
            index = np.full(int(node_tags.max()) + 1 if len(node_tags) else 1, -1, dtype=np.int64)
            index[node_tags] = np.arange(len(node_tags))
            blocks = []
            for _, surface in surfaces:
                types, _, nodes = gmsh.model.mesh.getElements(2, surface)
                for t, n in zip(types, nodes):
                    if t != 2:  # 3-node triangles only (a 2D mesh of order 1)
                        continue
                    # gmsh orients each face's triangles as the face lies in its solid
                    # (outward), so they are taken as they are.
                    blocks.append(index[np.asarray(n, dtype=np.int64).reshape(-1, 3)])
        finally:
            if gmsh.isInitialized():
                gmsh.finalize()
    faces = np.concatenate(blocks) if blocks else np.zeros((0, 3), dtype=np.int64)
    return coords, np.ascontiguousarray(faces)


def part_from_tessellation(path, vertices, faces, tessellate_s: float) -> Part:
    """The part of a tessellated file: welded like a mesh file, its report naming the file
    (``tessellate_s`` is added to its load time)."""
    path = os.fspath(path)
    try:
        size = os.path.getsize(path)
    except OSError:
        size = 0
    try:
        return Part._tessellated(vertices, faces, path, size, tessellate_s)
    except LoadError as e:
        raise LoadError(f"{path}: {e}") from None
