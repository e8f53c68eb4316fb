"""Spawn scene objects into a PyBullet world and read their poses back (no rospy).

Poses are (x, y, z, roll, pitch, yaw) in `world` (metres, radians, ROS fixed-axis roll-pitch-yaw, i.e. R = Rz Ry Rx,
the convention of ``p.getQuaternionFromEuler``) of the shape's local frame, its bounding-box centre.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pybullet as p

from pg_sim.scenes.colors import rgba
from pg_sim.scenes.meshes import build_mesh
from pg_sim.scenes.scene import ObjectSpec, Pose, SceneSpec
from pg_sim.scenes.shapes import get_builder


@dataclass(frozen=True)
class Contact:
    """Surface parameters of every spawned object (PyBullet units: friction coefficients, restitution 0-1)."""

    lateral_friction: float = 0.7
    spinning_friction: float = 0.001
    rolling_friction: float = 0.0002
    restitution: float = 0.0


DEFAULT_CONTACT = Contact()
OBJECT_DAMPING = float(np.float32(0.04))  # 1/s: linear and angular damping of every object (Bullet's multibody
# default; its rigid bodies default to none, and objects used to be multibodies: the same settling behaviour)


def build_shape(client: int, spec: ObjectSpec) -> tuple[int, int, float]:
    """Collision id, visual id and mass (kg) for ``spec`` (registry shape, or ``mesh`` from ``spec.mesh``).

    Raises ValueError for an unknown shape or a mesh object without a file, and FileNotFoundError for a missing mesh.
    """
    if spec.shape == "mesh":
        if not spec.mesh:
            raise ValueError(f"object {spec.name!r}: shape `mesh` needs a mesh file")
        return build_mesh(client, spec.mesh, spec.scale)
    return get_builder(spec.shape)(client, spec.size)


def spawn_object(client: int, spec: ObjectSpec, contact: Contact = DEFAULT_CONTACT,
                 shapes: tuple[int, int, float] | None = None) -> int:
    """Create ``spec`` as a dynamic rigid body at ``spec.pose`` with its colour; returns the PyBullet body id.
    ``shapes``: (collision id, visual id, mass kg) that ``build_shape(client, spec)`` returned earlier in this
    client (a cache: PyBullet shares a shape between bodies); None builds them.

    Objects are single-link bodies in maximal coordinates (Bullet's btRigidBody): their contacts are solved with
    split impulses, so a penetration (a finger wedged under a lying can, a screwdriver shaft pressed into the
    table) is pushed apart without adding velocity. As reduced-coordinate multibodies, such a penetration was
    resolved by a velocity that flung the object tens of centimetres (docs/RESULTS.md, "Household objects").

    Raises ValueError / FileNotFoundError as ``build_shape`` and RuntimeError if PyBullet refuses the body.
    """
    col, vis, mass = shapes if shapes is not None else build_shape(client, spec)
    mass = spec.mass if spec.mass is not None else mass
    x, y, z, roll, pitch, yaw = spec.pose
    quat = p.getQuaternionFromEuler([roll, pitch, yaw], physicsClientId=client)
    body = p.createMultiBody(
        baseMass=mass, baseCollisionShapeIndex=col, baseVisualShapeIndex=vis, basePosition=[x, y, z],
        baseOrientation=quat, useMaximalCoordinates=True, physicsClientId=client,
    )
    if body < 0:
        raise RuntimeError(f"PyBullet could not create object {spec.name!r} ({spec.shape})")
    p.changeVisualShape(body, -1, rgbaColor=rgba(spec.color), physicsClientId=client)
    p.changeDynamics(
        body, -1, lateralFriction=contact.lateral_friction, spinningFriction=contact.spinning_friction,
        rollingFriction=contact.rolling_friction, restitution=contact.restitution,
        linearDamping=OBJECT_DAMPING, angularDamping=OBJECT_DAMPING,
        activationState=p.ACTIVATION_STATE_ENABLE_SLEEPING,  # resting objects sleep until touched: faster steps
        physicsClientId=client,
    )
    return body


def spawn_scene(client: int, scene: SceneSpec, contact: Contact = DEFAULT_CONTACT) -> dict[str, int]:
    """Spawn every object of ``scene``; returns {object name: body id} in scene order."""
    return {o.name: spawn_object(client, o, contact) for o in scene.objects}


def object_pose(client: int, body: int) -> Pose:
    """World pose (x, y, z, roll, pitch, yaw) of a spawned object's local frame (its bounding-box centre)."""
    pos, quat = p.getBasePositionAndOrientation(body, physicsClientId=client)
    r, pi, y = p.getEulerFromQuaternion(quat, physicsClientId=client)
    return (pos[0], pos[1], pos[2], r, pi, y)


def set_object_pose(client: int, body: int, pose: Sequence[float]) -> None:
    """Teleport a body to ``pose`` (x, y, z, roll, pitch, yaw), zero its velocity and wake it: a sleeping rigid body
    moved in the air would otherwise stay there until something touches it."""
    x, y, z, roll, pitch, yaw = (float(v) for v in pose)
    quat = p.getQuaternionFromEuler([roll, pitch, yaw], physicsClientId=client)
    p.resetBasePositionAndOrientation(body, [x, y, z], quat, physicsClientId=client)
    p.resetBaseVelocity(body, [0.0, 0.0, 0.0], [0.0, 0.0, 0.0], physicsClientId=client)
    p.changeDynamics(body, -1, activationState=p.ACTIVATION_STATE_WAKE_UP, physicsClientId=client)
