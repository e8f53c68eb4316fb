"""The table's collision as a separate static body (the fast simulation mode, pg_sim.world.sim_mode).

The shared URDF carries the table as a link of the robot (one source of truth for the cell's geometry). In
PyBullet every dynamic link of a multibody is one contact island, so objects resting on that link are solved
with the moving robot at every step, and never sleep while an arm moves. `detach_table` gives the table's
collision box to a static rigid body at the same pose with the same contact parameters, and turns the link's
collision off: objects meet the same surface, while the robot's table link stays for rendering. The robot never
collided with its own table (no self-collision), so the new body ignores every robot link too.
"""

from __future__ import annotations

import pybullet as p

TABLE_LINK = "table"


def table_link(client: int, robot: int) -> int:
    """Link index of the table in the robot body; raises KeyError when the URDF has none."""
    for j in range(p.getNumJoints(robot, physicsClientId=client)):
        if p.getJointInfo(robot, j, physicsClientId=client)[12].decode() == TABLE_LINK:
            return j
    raise KeyError(f"the robot URDF has no link {TABLE_LINK!r}")


def detach_table(client: int, robot: int) -> int:
    """Move the table's collision (a box) to a new static body; returns its body id. Raises ValueError when the
    table link's collision is not one box."""
    link = table_link(client, robot)
    shapes = p.getCollisionShapeData(robot, link, physicsClientId=client)
    if len(shapes) != 1 or shapes[0][2] != p.GEOM_BOX:
        raise ValueError(f"the table link's collision must be one box, got {len(shapes)} shape(s)")
    _, _, _, extents, _, local_pos, local_orn = shapes[0]
    com_pos, com_orn = p.getLinkState(robot, link, physicsClientId=client)[:2]  # the shape data's frame
    pos, orn = p.multiplyTransforms(com_pos, com_orn, local_pos, local_orn)
    box = p.createCollisionShape(p.GEOM_BOX, halfExtents=[0.5 * e for e in extents], physicsClientId=client)
    # Without a visual shape PyBullet would draw the collision box (a second table in every camera image, its own
    # id in the segmentation): the body's visual is a speck inside the table, hidden by the robot's table link.
    speck = p.createVisualShape(p.GEOM_SPHERE, radius=1e-4, rgbaColor=[0, 0, 0, 0], physicsClientId=client)
    table = p.createMultiBody(0.0, box, speck, pos, orn, useMaximalCoordinates=True, physicsClientId=client)
    dyn = p.getDynamicsInfo(robot, link, physicsClientId=client)
    p.changeDynamics(table, -1, lateralFriction=dyn[1], restitution=dyn[5], rollingFriction=dyn[6],
                     spinningFriction=dyn[7], physicsClientId=client)
    if dyn[8] >= 0 and dyn[9] >= 0:  # contact damping / stiffness set on the link (-1: the engine's default)
        p.changeDynamics(table, -1, contactDamping=dyn[8], contactStiffness=dyn[9], physicsClientId=client)
    p.setCollisionFilterGroupMask(robot, link, 0, 0, physicsClientId=client)
    for j in range(-1, p.getNumJoints(robot, physicsClientId=client)):
        p.setCollisionFilterPair(table, robot, -1, j, 0, physicsClientId=client)
    return table
