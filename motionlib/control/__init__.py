"""Control: what a machine runs at 200 Hz, and the files it writes.

The shared controller's ``step(state, inputs) -> command`` (:class:`~.controller.SharedController`)
is the interface to a machine: a crane's control computer feeds it the measured joint state and
the operator's sticks and sends the returned joint velocity command to its valves. Everything
here runs on such a machine; nothing imports the simulator (:mod:`motionlib.sim`), which stands in
for the machine and the people in tests and studies.

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
    The vision source (001 section 2.4): camera measurements to a tip rate; the camera protocol.
accommodation
    The force-accommodation source, a damping-only impedance (001 section 2.5), and its options.
force_feedback
    Force feedback to the operator's hand controller: sensed and virtual forces through ``J_HC^T`` (001 eq. 6).
payload_command
    One payload held by several cranes (001 section 3): the broadcast MRF twist and the grasp-frame
    rate (001 eq. 1).
payload_source
    :class:`~.payload_source.PayloadSource`: the payload's rate at one crane's grasp frame, as its tip rate.
tracker
    Path tracking with nearest point and look-ahead (000 eq. 3).
joint_feedforward
    The joints' feedforward: the valve command that inverts each joint's lag and oil spring along the plan.
joint_servo
    The slew's model-following servo: its rate and drive pressure fed back against a well-damped model of it.
mixer
    The shared-control mixer ``p_s = c_a p_a + c_o p_o`` with weak zones (000 eqs. 4-5).
resolved_rate
    Weighted, damped pseudo-inverse with null-space term (000 eq. 2, 001 eq. 7).
rotator
    The grapple rotator's axis of the summing junction: the operator's rotator stick and the
    automation's planned rotator profile.
open_loop
    Open-loop execution for machines without joint sensors, with trajectory modification (003 Paper II).
gaze
    Head orientation to gaze: the linear model, its calibration and the target estimate (003 section 5.3).
gaze_recording
    Gaze files (eye point, calibrated model, recorded head stream) and selection by gaze (003 eq. 5.7).
runlog
    The 200 Hz run log and its HDF5 file.
ros_export
    Plans, library entries and run logs as ROS 2 bags and MCAP files (Foxglove), with the URDF's joint names.
metrics
    Smoothness (total jerk, 000 eq. 6), path deviation and the run summary.
"""
