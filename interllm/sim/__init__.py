"""MuJoCo execution of high-level actions (paper §III, §IV-B).

``world.World`` (the planners' WorldView) composes ``physics.MujocoWorld`` (model, poses,
contacts), ``belief.BeliefMap`` (the robot's map), ``navigator.Navigator`` and
``manipulator.Manipulator`` (mink IK); ``build`` turns a scene into an MjSpec, ``robot`` describes
the mobile manipulator, ``kinematics`` gives its link frames for the run log.
"""
