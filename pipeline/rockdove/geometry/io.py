"""The bird's and the body's meshes as files (``.npz`` arrays and a ``.json`` of the rest): the build cache's
format for them (:mod:`rockdove.graph.stages`)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ..resources import load_npz
from .types import Bird, MeshPart, Primvar


def _parts_arrays(parts_in) -> tuple[dict, list]:
    arrays, parts = {}, []
    for i, part in enumerate(parts_in):
        for f in ("points_m", "face_vertex_counts", "face_vertex_indices", "normals", "st"):
            arrays[f"{i}/{f}"] = np.ascontiguousarray(getattr(part, f))
        pv = {}
        for name, p in part.primvars.items():
            arrays[f"{i}/primvar/{name}"] = np.ascontiguousarray(p.values)
            pv[name] = {"interpolation": p.interpolation, "doc": p.doc}
        parts.append({"name": part.name, "material": part.material,
                      "display_color": [float(c) for c in part.display_color], "primvars": pv})
    return arrays, parts


def _parts_from(arrays: dict, meta_parts: list) -> tuple:
    parts = []
    for i, p in enumerate(meta_parts):
        pv = {n: Primvar(arrays[f"{i}/primvar/{n}"], d["interpolation"], d["doc"]) for n, d in p["primvars"].items()}
        parts.append(MeshPart(name=p["name"], points_m=arrays[f"{i}/points_m"],
                              face_vertex_counts=arrays[f"{i}/face_vertex_counts"],
                              face_vertex_indices=arrays[f"{i}/face_vertex_indices"], normals=arrays[f"{i}/normals"],
                              st=arrays[f"{i}/st"], material=p["material"], display_color=tuple(p["display_color"]),
                              primvars=pv))
    return tuple(parts)


def save_bird(bird, folder: Path) -> None:
    arrays, parts = _parts_arrays(bird.parts)
    np.savez(folder / "bird.npz", **arrays)
    (folder / "bird.json").write_text(json.dumps({"parts": parts}, sort_keys=True))


def load_bird(folder: Path):
    meta = json.loads((folder / "bird.json").read_text())
    return Bird(parts=_parts_from(load_npz(folder / "bird.npz"), meta["parts"]))


def save_body(body, folder: Path) -> None:
    arrays, parts = _parts_arrays([body.part])
    arrays.update({f"mesh/{f}": np.ascontiguousarray(getattr(body.mesh, f)) for f in ("vertices_m", "faces", "normals")})
    np.savez(folder / "body.npz", **arrays)
    (folder / "body.json").write_text(json.dumps({"parts": parts, "card_band_area_m2": body.card_band_area_m2},
                                                 sort_keys=True))


def load_body(folder: Path):
    from .bird import Body
    from .body import BodyMesh

    arrays = load_npz(folder / "body.npz")
    meta = json.loads((folder / "body.json").read_text())
    mesh = BodyMesh(**{f: arrays[f"mesh/{f}"] for f in ("vertices_m", "faces", "normals")})
    return Body(mesh=mesh, part=_parts_from(arrays, meta["parts"])[0], card_band_area_m2=meta.get("card_band_area_m2"))
