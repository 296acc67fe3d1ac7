"""Simulation: the simulated crane, its sensors, the model operators and the closed loops.

What stands in for the machine and the people in tests and studies. The controller it drives is
:mod:`motionlib.control`; this package may import it, never the other way round.

Modules
-------
plant
    :class:`~.plant.SimulatedCrane`: hydraulic joints (with the grapple rotator on a crane that
    has one), end stops and the swinging grapple.
hydraulics
    The joint actuators: valve lag, the shared pump (:mod:`motionlib.model.pump`), oil compliance (second order),
    relief bound (000 section 2.1).
contact
    Contact of the grapple with the ground and the scene's obstacles (spring-damper, Coulomb friction).
sensors
    The per-step sensor hook of the closed loop: objects with ``sense(sim) -> None``, called with
    the simulated crane before the operator and the controller act; the force sensor.
camera
    The simulated camera on the grapple that feeds the vision source (001 section 2.4), and
    ``VisionOptions`` / :func:`~.camera.vision_source` for ``execute``.
payload
    The log carried by two cranes as a rigid body on spring-damper grips, and its internal force (001 section 3).
operators
    Simulated operators: passive, scripted (CSV), novice and expert models (the experts with habits).
hand_controller
    The force-reflecting stick the model operators hold with force feedback: a mass-spring-damper per axis.
operator_model
    The simulated operator's step compiled: perception delay, takeover, corrections, minimum-jerk stick.
loop
    :func:`~.loop.run_closed_loop`: sensors + controller + plant + operator at the control rate.
fast_loop
    The same closed loop run compiled, many steps per call, on the objects' arrays (same results).
execute
    :func:`~.execute.execute`: one call that sets all of the above up and runs it.
dual_scenario
    Dual-crane scenario files: two cranes with base poses and calibration errors, one log, one command.
dual
    :func:`~.dual.execute_dual`: two simulated cranes carry one log, with force-moment accommodation.
commands
    :func:`~.commands.execute_command`: a run started and continued by discrete commands (003 section 5.1.1).
"""
