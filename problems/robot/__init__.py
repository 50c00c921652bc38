"""The robot's view of a plan: relative joint angles with an encoder's zero and sign, each
physical drive's torque and limit, left and right legs, whole strides (``joint_space``)."""

from problems.robot.joint_space import JointSpace, joint_space

__all__ = ["JointSpace", "joint_space"]
