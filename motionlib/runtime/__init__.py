"""Runtime: the 200 Hz shared-control loop and the simulated crane it runs against.

Modules
-------
control_types
    Modes M1-M6, flags, authority, measured state, operator input, status, parameters, events.
controller
    :class:`~.controller.SharedController`: one ``step(state, inputs) -> qd_cmd`` (000 section 2).
command
    The controller's command law compiled: mode logic, ``p_s``, resolved rate, limits (steps 3-5).
sources
    Input sources of the summing junction (001 Fig. 1): joysticks, path tracker, position source.
frames_source
    :class:`~.frames_source.FrameSource`: any Cartesian source acting on an MRF in a CRF (001 eq. 1).
vision
    A simulated camera on the grapple and the vision source (001 section 2.4); ``VisionOptions``
    and :func:`~.vision.vision_source` for ``execute``.
sensors
    The per-step sensor hook of the closed loop: objects with ``sense(sim) -> None``, called with
    the simulated crane before the operator and the controller act (the camera; force sensors).
contact
    Ground contact of the grapple in the simulated crane (spring-damper, Coulomb friction).
accommodation
    The force-accommodation source, a damping-only impedance (001 section 2.5), its force sensor
    and its options for ``execute``.
payload
    One payload held by several cranes (001 section 3): the broadcast MRF twist, the grasp-frame rate
    (001 eq. 1), the log as a rigid body on spring-damper grips, the internal force.
payload_source
    :class:`~.payload_source.PayloadSource`: the payload's rate at one crane's grasp frame, as its tip rate.
dual_scenario
    Dual-crane scenario files: two cranes with base poses and calibration errors, one log, one command.
dual
    :func:`~.dual.execute_dual`: two simulated cranes carry one log, with force-moment accommodation.
tracker
    Path tracking with nearest point and look-ahead (000 eq. 3).
mixer
    The shared-control mixer ``p_s = c_a p_a + c_o p_o`` with weak zones (000 eqs. 4-5).
resolved_rate
    Weighted, damped pseudo-inverse with null-space term (000 eq. 2, 001 eq. 7).
operators
    Simulated operators: passive, scripted (CSV), novice and expert models (the experts with habits).
operator_model
    The simulated operator's step compiled: perception delay, takeover, corrections, minimum-jerk stick.
plant
    :class:`~.plant.SimulatedCrane`: hydraulic joints (with the grapple rotator on a crane that
    has one), end stops and the swinging grapple.
hydraulics
    The joint actuators: valve lag, oil compliance (second order), relief bound (000 section 2.1).
pump
    Flow sharing of the one load-sensing pump between the joints (the rotator's included).
rotator
    The grapple rotator's axis of the summing junction: the operator's rotator stick and the
    automation's planned rotator profile.
loop
    :func:`~.loop.run_closed_loop`: sensors + controller + plant + operator at the control rate.
fast_loop
    The same closed loop run compiled, many steps per call, on the objects' arrays (same results).
runlog
    The 200 Hz run log and its HDF5 file.
metrics
    Smoothness (total jerk, 000 eq. 6), path deviation and the run summary.
execute
    :func:`~.execute.execute`: one call that sets all of the above up and runs it.
open_loop
    Open-loop execution for machines without joint sensors, with trajectory modification (003 Paper II).
gaze
    Head orientation to gaze: the linear model, its calibration and the target estimate (003 section 5.3).
"""
