"""MuJoCo execution of high-level actions (paper §III, §IV-B).

``world.World`` (the planners' WorldView) composes ``physics.MujocoWorld`` (model, poses,
contacts), ``belief.BeliefMap`` (the robot's map), ``navigator.Navigator`` and
``manipulator.Manipulator`` (mink IK). The manipulator's parts: ``base_poses`` (where the base
stands for each trial), ``grasp_goals`` (where the gripper goes), ``arm_ik`` (the small IK model
around a furniture and what is solved on it), ``trials`` (one trial per base pose and their
outcome). ``build`` turns a scene into an MjSpec, ``robot`` describes the mobile manipulator,
``kinematics`` gives its link frames for the run log.
"""
