"""Motions as values: each joint's world transform at every frame (:class:`Motion`), no USD. Both last
:data:`DURATION_S` at :data:`FPS` frames a second and loop (the walk's last frame is its first moved on by whole
strides: root motion in the pelvis).

``idle``: breathing (the chest rises 0.8 mm, one breath a loop: 30 a minute, chosen) and saccadic head turns and
tilts (0.1 s moves between holds: 18 deg of yaw over neck_04, neck_05 and head, 8 deg of tilt, 5 of nod).

``walk``, the head-bobbing gait:

- one head cycle per step (Necker 2007, J. Comp. Physiol. A 193:1177): a hold, the head locked in space (position,
  pitch, yaw, roll; Frost 1978, J. Exp. Biol. 74:187; Troje & Frost 2000, J. Exp. Biol. 203:935) while the body
  goes on along +Z, then a thrust to the next hold;
- :data:`STEP_S` 0.2 s a step ("five to eight times a second", A. Blaisdell in Live Science, 2019); :data:`HOLD`
  60 % of it in hold (~63 % of walking time in compilations of the pigeon literature); the thrust covers one step
  length (Kroker 2013, MSc thesis, Queen's University), the head thrust "about 5 cm" relative to the body (M. Land in
  Live Science, 2019): :data:`STEP_M` 4 cm, 0.2 m/s;
- the hold falls in single support and the body's speed peaks with the neck's extension (Fujita 2002, J. Comp.
  Physiol. A 188, egrets "similar to those of pigeons"): the trunk surges :data:`SURGE` 30 % mid-thrust;
- duty factor :data:`DUTY` 0.6 (a walk: a foot always down), swing lift 12 mm; the femur stays with the pelvis
  (birds walk from the knee), tibiotarsus and tarsus solved to the planted foot, the heel bending back.

The neck takes the head's offset from the trunk as an S-bend (:data:`NECK_BEND`: the head keeps its orientation)
and a change of length, solved at every frame: neighbouring neck joints turn apart by the bend angle alone (~14
deg), so a card whose weights blend two of them stays within 1 % of rigid under linear blend skinning, the only
skinning of glTF and three.js, and cards turn with the skin they lie on."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: Frames (USD time codes) per second and the length of each motion, seconds.
FPS, DURATION_S = 60, 2.0
#: Walk (module docstring): step period s, step length m, hold fraction, step phase where the hold starts, duty
#: factor, swing lift m, body bob m, sway m, roll deg.
STEP_S, STEP_M, HOLD, HOLD_START, DUTY = 0.2, 0.04, 0.6, 0.25, 0.6
LIFT_M, BOB_M, SWAY_M, ROLL_DEG = 0.012, 0.0015, 0.002, 1.5
#: The trunk's surge (its forward speed varies by this fraction of the mean, fastest mid-thrust) and how much
#: lower it walks than it stands, metres (the knees bend more: the legs reach the footholds).
SURGE, CROUCH_M = 0.3, 0.004


@dataclass(frozen=True)
class Motion:
    """``world`` (F, J, 4, 4) float64: each joint's frame in the world at frame f (time f / ``fps`` s): its
    rotation and its position, metres, column vectors; at rest the identity at the joint's rest position, so a
    point x bound to joint j moves to ``world[f, j] @ inv(rest_j) @ x``."""

    name: str
    fps: float
    world: np.ndarray

    def local(self, skel) -> np.ndarray:
        """(F, J, 4, 4): each joint's transform relative to its parent's (the root's: its world transform)."""
        parent = np.where(skel.parents < 0, 0, skel.parents)
        out = np.linalg.inv(self.world[:, parent]) @ self.world
        out[:, skel.parents < 0] = self.world[:, skel.parents < 0]
        return out


def _ease(x):
    """Smootherstep (zero velocity and acceleration at both ends) of x clipped to [0, 1]."""
    x = np.clip(x, 0.0, 1.0)
    return x * x * x * (x * (6.0 * x - 15.0) + 10.0)


def _rot(axis: int, angle_rad) -> np.ndarray:
    """(..., 3, 3) rotations about world axis 0 (x), 1 (y) or 2 (z) by ``angle_rad`` (...)."""
    from scipy.spatial.transform import Rotation

    a = np.asarray(angle_rad, float)
    return Rotation.from_euler("xyz"[axis], a.reshape(-1, 1)).as_matrix().reshape(a.shape + (3, 3))


def _between(u, v) -> np.ndarray:
    """(F, 3, 3) the least rotation turning the unit vector u (3,) into the directions v (F, 3)."""
    from scipy.spatial.transform import Rotation

    v = v / np.linalg.norm(v, axis=-1, keepdims=True)
    axis = np.cross(u, v)
    sin = np.linalg.norm(axis, axis=-1, keepdims=True)
    return Rotation.from_rotvec(axis / np.maximum(sin, 1e-12) * np.arctan2(sin, v @ u[:, None])).as_matrix()


def _frames(skel, n):
    world = np.tile(np.eye(4), (n, len(skel.names), 1, 1))
    world[..., :3, 3] = skel.rest_m
    return world


def _carry(world, skel, names, m):
    """Joints ``names`` carried rigidly by the (F, 4, 4) transforms ``m`` from their rest frames."""
    j = skel.indices(*names)
    rest = np.tile(np.eye(4), (len(j), 1, 1))
    rest[:, :3, 3] = skel.rest_m[j]
    world[:, j] = m[:, None] @ rest[None]


def _descendants(skel, name) -> list:
    keep = [skel.index(name)]
    for j, p in enumerate(skel.parents):
        if p in keep:
            keep.append(j)
    return [skel.names[j] for j in keep]


def idle(skel, fps: int = FPS) -> Motion:
    """Breathing, saccadic head turns and tilts (module docstring)."""
    t = np.arange(int(round(DURATION_S * fps)) + 1) / fps

    def keys(*moves):  # (start s, value) steps of 0.1 s each, from 0 back to 0
        out, last = np.zeros_like(t), 0.0
        for start, value in moves:
            out += (value - last) * _ease((t - start) / 0.1)
            last = value
        return np.deg2rad(out)

    yaw = keys((0.25, 18.0), (0.9, -12.0), (1.55, 0.0))
    tilt, nod = keys((0.35, 8.0), (0.95, -5.0), (1.6, 0.0)), keys((1.2, -5.0), (1.8, 0.0))
    world = _frames(skel, len(t))
    breath = 0.0008 * (0.5 - 0.5 * np.cos(2 * np.pi * t / DURATION_S))
    m = np.tile(np.eye(4), (len(t), 1, 1))
    m[:, :3, 3] = breath[:, None] * np.array([0.0, 0.8, 0.6])
    _carry(world, skel, _descendants(skel, "chest"), m)
    for name, share, extra in (("neck_04", 0.25, None), ("neck_05", 0.35, None), ("head", 0.4, (tilt, nod))):
        r = _rot(1, share * yaw)
        if extra is not None:
            r = r @ _rot(2, extra[0]) @ _rot(0, extra[1])
        pivot = world[:, skel.index(name), :3, 3].copy()
        turn = np.tile(np.eye(4), (len(t), 1, 1))
        turn[:, :3, :3], turn[:, :3, 3] = r, pivot - (r @ pivot[..., None])[..., 0]
        for j in skel.indices(*_descendants(skel, name)):
            world[:, j] = turn @ world[:, j]
    return Motion("idle", fps, world)


def _two_bone(knee, foot, a: float, b: float) -> np.ndarray:
    """(F, 3) the ankle: ``a`` from the knee (F, 3), ``b`` from the foot (F, 3), bending back (-Z)."""
    d = foot - knee
    dist = np.minimum(np.linalg.norm(d, axis=-1), a + b - 1e-9)
    dn = d / np.linalg.norm(d, axis=-1, keepdims=True)
    back = np.array([0.0, 0.0, -1.0]) - (dn @ np.array([0.0, 0.0, -1.0]))[:, None] * dn
    back /= np.linalg.norm(back, axis=-1, keepdims=True)
    cos = np.clip((a * a + dist * dist - b * b) / (2 * a * dist), -1.0, 1.0)
    return knee + a * (cos[:, None] * dn + np.sqrt(1 - cos * cos)[:, None] * back)


#: The neck's S-bend: each neck joint's pitch (neck_01 .. head) in units of the bend angle; neighbours differ by
#: one unit, the head's is 0 (it keeps the trunk's orientation).
NECK_BEND = np.array([1.0, 2.0, 3.0, 2.0, 1.0, 0.0])


def _neck_shape(joints, offset):
    """(F,) bend angles (rad) and (F,) length scales of the neck whose joints rest at ``joints`` (6, 3) that move the
    head by ``offset`` (F, 3) in the trunk's frame (its y and z; Newton's method from the rest shape)."""
    seg = joints[1:] - joints[:-1]

    def head(x):  # (F, 2) the head's (y, z) from neck_01 for x = (angle, scale) (F, 2)
        r = _rot(0, np.outer(x[:, 0], NECK_BEND[:-1]))
        return x[:, 1:2] * np.einsum("fsij,sj->fi", r, seg)[:, 1:]

    goal = (joints[-1] - joints[0])[1:] + offset[:, 1:]
    x = np.tile([0.0, 1.0], (len(offset), 1))
    for _ in range(8):
        jac = np.stack([(head(x + h) - head(x - h)) / 2e-6 for h in np.eye(2) * 1e-6], axis=-1)
        x -= np.linalg.solve(jac, (head(x) - goal)[..., None])[..., 0]
    return x[:, 0], x[:, 1]


def walk(skel, fps: int = FPS) -> Motion:
    """The head-bobbing walk along +Z (module docstring)."""
    t = np.arange(int(round(DURATION_S * fps)) + 1) / fps
    p, stride = t / STEP_S, t / (2 * STEP_S)  # step and stride phases (cumulative)
    rest = skel.rest_m
    sway = np.sin(2 * np.pi * (stride - 0.05))
    body = np.tile(np.eye(4), (len(t), 1, 1))  # the trunk's rigid motion
    pelvis = rest[skel.index("pelvis")]
    body[:, :3, :3] = _rot(2, np.deg2rad(-ROLL_DEG) * sway)
    thrust_mid = HOLD_START + 0.5 * (1.0 + HOLD)
    ahead = STEP_M * (p + SURGE / (2 * np.pi) * np.sin(2 * np.pi * (p - thrust_mid)))
    body[:, :3, 3] = (pelvis - (body[:, :3, :3] @ pelvis) + np.stack(
        [SWAY_M * sway, BOB_M * np.cos(2 * np.pi * (p - 0.6)) - CROUCH_M, ahead], 1))
    world = _frames(skel, len(t))
    trunk = [n for n in skel.names if not n.startswith(("neck_", "head", "ankle", "foot", "toe"))]
    _carry(world, skel, trunk, body)
    # the head: locked in the hold, thrust one step on; the neck joints take their share of its offset
    head = skel.index("head")
    k, q = np.divmod(p - HOLD_START, 1.0)
    thrust = np.where(q < HOLD, 0.0, _ease((q - HOLD) / (1.0 - HOLD)))
    carried = (body @ np.append(rest[head], 1.0))[:, :3]
    target = np.stack([carried[:, 0], np.full_like(t, rest[head, 1]),
                       rest[head, 2] + STEP_M * (HOLD_START + k + thrust)], 1)
    neck = skel.indices(*[f"neck_{i:02d}" for i in range(1, 6)], "head")
    offset = np.einsum("fji,fj->fi", body[:, :3, :3], target - carried)  # in the trunk's frame
    angle, scale = _neck_shape(rest[neck], offset)
    turn = _rot(0, np.outer(angle, NECK_BEND))  # (F, 6, 3, 3): each neck joint's pitch in the trunk's frame
    seg = rest[neck][1:] - rest[neck][:-1]
    pos = rest[neck][0] + np.concatenate([np.zeros((len(t), 1, 3)), np.cumsum(
        scale[:, None, None] * np.einsum("fsij,sj->fsi", turn[:, :-1], seg), axis=1)], axis=1)
    frames = np.tile(np.eye(4), (len(t), len(neck), 1, 1))
    frames[..., :3, :3], frames[..., :3, 3] = turn, pos
    world[:, neck] = body[:, None] @ frames
    world[:, head, :3, :3] = np.eye(3)  # the head keeps its orientation in space (the trunk's roll aside)
    for side, offset in (("L", 0.0), ("R", 0.5)):
        kk, phase = np.divmod(stride - offset, 1.0)
        knee, ankle, foot = skel.indices(f"knee_{side}", f"ankle_{side}", f"foot_{side}")
        swing = np.clip((phase - DUTY) / (1.0 - DUTY), 0.0, 1.0)
        z = rest[knee, 2] + 2 * STEP_M * (offset + kk + 0.3 + _ease(swing))  # mid-stance under the knee
        lift = np.where(phase >= DUTY, LIFT_M * np.sin(np.pi * swing), 0.0)
        pos = np.stack([np.full_like(t, rest[foot, 0]), rest[foot, 1] + lift, z], 1)
        world[:, foot, :3, 3] = pos
        toes = _descendants(skel, f"foot_{side}")[1:]
        shift = np.tile(np.eye(4), (len(t), 1, 1))
        shift[:, :3, 3] = pos - rest[foot]
        _carry(world, skel, toes, shift)
        kpos = world[:, knee, :3, 3]
        a, b = (np.linalg.norm(rest[knee] - rest[ankle]), np.linalg.norm(rest[ankle] - rest[foot]))
        apos = _two_bone(kpos, pos, a, b)
        world[:, ankle, :3, 3] = apos
        world[:, knee, :3, :3] = _between((rest[ankle] - rest[knee]) / a, apos - kpos)
        world[:, ankle, :3, :3] = _between((rest[foot] - rest[ankle]) / b, pos - apos)
    return Motion("walk", fps, world)


#: Motion name -> the function that makes it from a :class:`rockdove.rig.skeleton.Skeleton`.
MOTIONS = {"idle": idle, "walk": walk}
