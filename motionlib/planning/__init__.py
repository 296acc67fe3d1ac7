"""Offline planning: start configuration + goal point -> verified minimum-time trajectory.

Modules, in pipeline order
--------------------------
path
    Collision-free tip path with OMPL, simplified and fitted with a spline (000 section 2.3).
spline
    :class:`~.spline.TipSpline`: arc-length cubic spline with nearest-point search.
redundancy
    Minimum-time Bézier telescope profile with CasADi + IPOPT (003 eqs. 4.14-4.16).
phase_plane
    Velocity-limited path speed bound and time (003 eqs. 4.8-4.12).
timing
    Time-optimal time scaling with TOPPRA under the crane's limits.
planner
    :func:`~.planner.plan`: the stages above plus the dense verification, as one call.
trajectory
    :class:`~.trajectory.Trajectory` and its HDF5 layout (plan files, library entries).
"""
