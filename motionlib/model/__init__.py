"""The crane and its world: what every later phase plans, stores and runs against.

Modules
-------
crane_model
    Crane model files (``cranes/<name>.yaml``): :class:`~.crane_model.CraneModel`, read strictly
    (optional ``rotator`` section: the grapple rotator q5).
kinematics
    :class:`~.kinematics.Crane`: forward kinematics on arrays, closed-form inverse kinematics
    (003 eq. 4.15), the tip Jacobian (000 eq. 1), reachability, link and grapple capsules; with the
    optional grapple rotator q5, the log's yaw ``q1 + q5`` and log-point Jacobians.
fast_kinematics
    The same tip kinematics on plain floats, for the 200 Hz loop and the simulator.
symbolic
    ``CASADI_OPS``: the kinematics' functions on CasADi expressions (NLPs, the collision checker's Jacobians).
limits
    Joint position, velocity, acceleration and shared-pump flow limits as objects
    (003 eqs. 4.8-4.10), their TOPPRA constraints and the dense sample check.
pump
    Flow sharing of the one load-sensing pump between the joints (the rotator's included): the simulated
    crane's pump and what the slew's servo predicts of it.
scene
    Obstacle scenes (``obstacles/*.yaml``): obstacles, named starts, points and regions.
collision
    Crane-against-scene collision and distance queries with python-fcl.
urdf
    The crane as URDF.
frames
    Control frames (001 section 2): MRF points on the grapple and log, base/slew/view CRFs and
    the rigid-body velocity transformation of 001 eq. 1.
embedded
    Crane and scene models embedded in plan, library and run-log files (files that need nothing else).
scene_check
    A scene checked for a crane: every start's clearance, every point's reach and clearance.
hanging_body
    The grapple and a held log as one rigid pendulum: its equivalent length (the simulated crane's and the
    planner's loaded pendulum).
"""
