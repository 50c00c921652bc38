"""The robot's view of a plan: relative joint angles with an encoder's zero and sign, each
physical drive's torque and limit, left and right legs, whole strides (``joint_space``); a
robot's URDF as the walking biped (``walker_from_urdf``)."""

from problems.robot.joint_space import JointSpace, joint_space
from problems.robot.urdf_walker import UrdfWalker, read_urdf_walker, urdf_angles, walker_from_urdf

__all__ = [
    "JointSpace",
    "UrdfWalker",
    "joint_space",
    "read_urdf_walker",
    "urdf_angles",
    "walker_from_urdf",
]
