"""Offline planning: start configuration + goal point -> verified minimum-time trajectory, shaped against the swing.

Modules, in pipeline order
--------------------------
path
    Collision-free tip path with OMPL, simplified and fitted with a spline (000 section 2.3);
    :func:`~.path.solve_ompl`, the OMPL call for any dimension.
slew_cut
    The cut that keeps a tip path's slew within its limits (the path goes the other way round).
start_escape
    Leaving a start inside the searches' clearance: only contact counts in a ball around it.
jointspace
    Joint-space paths (straight line or OMPL) to goal configurations, and the joint-space baseline.
trajopt
    Minimum-time joint motion near a valid joint path (CasADi + IPOPT direct transcription,
    sequential convexification of the clearances).
joint_to_tip
    A joint path in the product's shape: tip spline of its forward kinematics and a fitted telescope profile.
lower_bound
    Pump-aware lower bound on the duration of any verified motion of a query.
spline
    :class:`~.spline.TipSpline`: arc-length cubic spline with nearest-point search.
redundancy
    Minimum-time Bézier telescope profile with CasADi + IPOPT (003 eqs. 4.14-4.16).
rotator
    The grapple rotator's Bézier profile along the path, so a carried log arrives aligned (000 section 3.3).
phase_plane
    Velocity-limited path speed bound and time (003 eqs. 4.8-4.12).
timing
    Time-optimal time scaling with TOPPRA under the crane's limits.
time_law
    The time law ``s(t)`` as a piecewise polynomial (TOPPRA's constant-acceleration profile) and its
    shaped versions: impulses convolved with it, a moving-average box, a uniform stretch.
swing
    The grapple's swing predicted from a planned tip motion (linearised damped pendulum), its
    residual amplitude and the time to settled.
settled_law
    The minimum-time law along a timed path with the grapple pendulum in the problem (IPOPT): still at the
    end, robust to the rod length, a bounded swing on the way.
shaping
    Swing shaping of a motion's time law (ZV / ZVD input shaping, fitted to the motion, jerk-limited):
    the shortest candidate whose predicted residual swing is within tolerance and that verifies.
smoothness
    Total jerk (000 eq. 6) of a sampled tip motion, shared with the runtime's measures.
verification
    :class:`~.verification.Verifier`: dense limit and collision re-check; :func:`~.verification.time_and_verify`.
planner
    :func:`~.planner.plan`: path candidates from several sources through the stages above; the
    fastest verified wins.
trajectory
    :class:`~.trajectory.Trajectory` and its HDF5 layout (plan files, library entries).
"""
