"""The rock dove's skeleton as values: joint names (UsdSkel paths), parents and rest positions, no USD.

Joints are placed from the geometry's landmarks (metres, Y up, facing +Z; the bird's left is +X; see
:func:`build_skeleton`): the torso chain, the neck at neck coordinates :data:`NECK_S`, the tail, the folded wing,
and per leg hip, knee, ankle (the intertarsal joint, where the tarsus leaves the belly's feathers), foot and toes.
Every joint frame is axis-aligned at rest (its bind transform is a translation), so a joint's rotation reads in
world axes: x pitches, y turns, z rolls."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import UsageError

#: Height of the intertarsal (ankle) joint on the tarsus, metres: where the tarsus leaves the belly's feathers.
ANKLE_JOINT_Y_M = 0.030
#: Knee (forward and up from the ankle, so the tibiotarsus is ~5 cm) and hip (behind and above it), metres, left.
KNEE_M, HIP_M = (0.019, 0.075, 0.038), (0.020, 0.086, 0.012)
#: Pelvis (between the hips), tail base (in the rump), metres.
PELVIS_M, TAIL_BASE_M = (0.0, 0.088, -0.004), (0.0, 0.066, -0.055)
#: Folded wing, left side: shoulder, elbow, hand, metres (along the rows of rockdove.geometry.plumage.WING_ROWS).
WING_M = ((0.034, 0.126, 0.030), (0.042, 0.106, -0.012), (0.040, 0.094, -0.048))
#: Neck coordinates of neck_01 .. neck_05 and of the head joint.
NECK_S = (0.0, 0.2, 0.4, 0.6, 0.8, 1.0)
#: Toe names in the order of rockdove.geometry.parts.TOES (inner -28 deg, middle, outer +28 deg, hind).
TOE_NAMES = ("toe_inner", "toe_middle", "toe_outer", "toe_hind")


@dataclass(frozen=True)
class Skeleton:
    """``names`` (J,) leaf names, unique; ``parents`` (J,) int, -1 for the root, each parent before its children;
    ``rest_m`` (J, 3) float64 world positions at rest, metres (frames axis-aligned)."""

    names: tuple
    parents: np.ndarray
    rest_m: np.ndarray

    @property
    def paths(self) -> tuple:
        """UsdSkel joint paths: ``pelvis``, ``pelvis/spine_01``, ..."""
        out = []
        for name, p in zip(self.names, self.parents):
            out.append(name if p < 0 else f"{out[p]}/{name}")
        return tuple(out)

    def index(self, name: str) -> int:
        try:
            return self.names.index(name)
        except ValueError:
            raise UsageError(f"joint={name!r} is not in the skeleton; joints are {list(self.names)}") from None

    def indices(self, *names) -> list:
        return [self.index(n) for n in names]


def build_skeleton() -> Skeleton:
    """The rock dove's 34 joints (module docstring)."""
    from ..geometry import parts, plumage, sdf

    base, top = np.asarray(sdf.NECK_BASE_M, float), np.asarray(sdf.NECK_TOP_M, float)
    pelvis = np.asarray(PELVIS_M)
    spec = [("pelvis", None, pelvis)]
    spec += [(n, p, pelvis + f * (base - pelvis)) for n, p, f in
             (("spine_01", "pelvis", 0.25), ("spine_02", "spine_01", 0.5), ("chest", "spine_02", 0.75))]
    chain = ["chest"] + [f"neck_{i:02d}" for i in range(1, 6)] + ["head"]
    spec += [(n, chain[i], base + s * (top - base)) for i, (n, s) in enumerate(zip(chain[1:], NECK_S))]
    spec += [("tail_base", "pelvis", np.asarray(TAIL_BASE_M)),
             ("tail_fan", "tail_base", np.array([0.0, *plumage.TAIL_ROOT_M]))]
    for side, tag in ((1.0, "L"), (-1.0, "R")):
        mirror = np.array([side, 1.0, 1.0])
        parent = "chest"
        for name, pos in zip(("wing_shoulder", "wing_elbow", "wing_hand"), WING_M):
            spec.append((f"{name}_{tag}", parent, mirror * pos))
            parent = f"{name}_{tag}"
        hip = np.array([side * parts.HIP_M[0], *parts.HIP_M[1:]])  # the top of the tarsus tube
        foot = np.array([side * parts.ANKLE_M[0], *parts.ANKLE_M[1:]])
        ankle = foot + (hip - foot) * (ANKLE_JOINT_Y_M - foot[1]) / (hip[1] - foot[1])
        for name, parent, pos in (("hip", "pelvis", mirror * HIP_M), ("knee", "hip", mirror * KNEE_M),
                                  ("ankle", "knee", ankle), ("foot", "ankle", foot)):
            spec.append((f"{name}_{tag}", f"{parent}_{tag}" if parent != "pelvis" else parent, pos))
        for toe, (yaw_deg, length) in zip(TOE_NAMES, parts.TOES):
            yaw = np.deg2rad(yaw_deg * side)
            spec.append((f"{toe}_{tag}", f"foot_{tag}", foot + 0.4 * length * np.array([np.sin(yaw), -0.04,
                                                                                          np.cos(yaw)])))
    names = tuple(n for n, _, _ in spec)
    parents = np.array([-1 if p is None else names.index(p) for _, p, _ in spec], dtype=np.int64)
    return Skeleton(names=names, parents=parents, rest_m=np.array([np.asarray(x, float) for _, _, x in spec]))
