"""Data types that geometry hands to the USD stage (docs/design.md, "Geometry" section): plain numpy arrays in
metres, Y up, bird facing +Z; geometry knows nothing of USD."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np

from ..errors import UsageError

#: Allowed primvar interpolations (the USD names, as plain strings).
INTERPOLATIONS = ("constant", "uniform", "vertex", "faceVarying")

#: Allowed material names of a :class:`MeshPart`.
MATERIALS = ("body", "feather", "plumage", "beak", "eye", "cere", "leg", "eyering", "claw")


def point_bounds(points) -> np.ndarray:
    """``[min, max]`` per coordinate of (N, D) points, shape (2, D), their dtype: the values of
    ``points.min(axis=0)`` and ``points.max(axis=0)`` from contiguous columns (numpy 2.4 reduces the first axis of
    an (N, 3) array element by element: 12.6 ms for 112k float32 points against 0.27 ms)."""
    columns = np.ascontiguousarray(np.asarray(points).T)
    return np.stack([columns.min(axis=1), columns.max(axis=1)])


def unit(v: np.ndarray) -> np.ndarray:
    """``v`` scaled to unit length along its last axis (zero vectors stay zero)."""
    return v / np.maximum(np.linalg.norm(v, axis=-1, keepdims=True), 1e-20)


@dataclass(frozen=True)
class Primvar:
    """One extra per-mesh attribute: ``values`` (V,) or (V, k) for ``"vertex"``, (F, ...) for ``"uniform"``, one
    value for ``"constant"``; ``doc``: one line, what the values are and their unit."""

    values: np.ndarray
    interpolation: str = "vertex"
    doc: str = ""

    def __post_init__(self):
        if self.interpolation not in INTERPOLATIONS:
            raise UsageError(f"interpolation={self.interpolation!r} is not allowed; use one of {INTERPOLATIONS}")


@dataclass(frozen=True)
class MeshPart:
    """One mesh of the bird, ready to be written as a ``UsdGeom.Mesh`` named ``name`` (fields: docs/design.md,
    "Geometry"; ``material`` one of :data:`MATERIALS`, ``primvars`` name -> :class:`Primvar`)."""

    name: str
    points_m: np.ndarray
    face_vertex_counts: np.ndarray
    face_vertex_indices: np.ndarray
    normals: np.ndarray
    st: np.ndarray
    material: str
    display_color: tuple
    primvars: dict = field(default_factory=dict)

    def __post_init__(self):
        if self.material not in MATERIALS:
            raise UsageError(f"material={self.material!r} is not allowed; use one of {MATERIALS}")

    @property
    def n_points(self) -> int:
        return int(self.points_m.shape[0])


def triangle_part(name: str, pieces, material: str, display_color: tuple, primvars: dict | None = None) -> MeshPart:
    """One triangle :class:`MeshPart` from ``pieces`` of ``(points (V, 3), normals (V, 3), st (V, 2), faces (F, 3))``,
    each piece's faces indexing its own points."""
    offsets = np.cumsum([0] + [len(p[0]) for p in pieces[:-1]])
    points, normals, st = (np.concatenate([p[i] for p in pieces]) for i in range(3))
    faces = np.concatenate([p[3] + o for p, o in zip(pieces, offsets)])
    return MeshPart(name=name, points_m=points.astype(np.float32),
                    face_vertex_counts=np.full(len(faces), 3, dtype=np.int32),
                    face_vertex_indices=faces.reshape(-1).astype(np.int32), normals=normals.astype(np.float32),
                    st=st.astype(np.float32), material=material, display_color=display_color, primvars=primvars or {})


def drop_unreferenced_points(part: MeshPart) -> MeshPart:
    """``part`` without the points no face references (and their normals, st and vertex primvars), or ``part``
    itself when every point is used: NVIDIA's ``UnusedMeshTopologyChecker`` rejects unused points. Kept points
    keep their order; uniform, faceVarying and constant primvars do not follow points and stay as they are."""
    used = np.zeros(part.n_points, dtype=bool)
    used[np.asarray(part.face_vertex_indices, dtype=np.int64)] = True
    if used.all():
        return part
    new_index = np.cumsum(used, dtype=np.int64) - 1
    primvars = {name: dataclasses.replace(pv, values=np.asarray(pv.values)[used])
                if pv.interpolation == "vertex" else pv for name, pv in part.primvars.items()}
    return dataclasses.replace(
        part, points_m=part.points_m[used], normals=part.normals[used], st=part.st[used], primvars=primvars,
        face_vertex_indices=new_index[part.face_vertex_indices].astype(part.face_vertex_indices.dtype))


@dataclass(frozen=True)
class Bird:
    """The whole bird: its :class:`MeshPart` s in order (``Body`` one closed surface, one ``NeckFeathers``)."""

    parts: tuple

    def part(self, name: str) -> MeshPart:
        """The part called ``name``; ValueError naming the known parts if absent."""
        for p in self.parts:
            if p.name == name:
                return p
        raise UsageError(f"name={name!r} is not a part; parts are {[p.name for p in self.parts]}")

    @property
    def names(self) -> tuple:
        return tuple(p.name for p in self.parts)
