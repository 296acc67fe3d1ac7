"""Figures and the 3D viewer (the only subpackage that draws).

Modules
-------
figures
    Matplotlib figures without pyplot (no global backend, no figure left open).
plan_plots
    Figures of a plan: phase plane (003 Fig. 4.1), joints against limits, the path in 3D.
run_plots
    Figures of a shared-control run (``motionlib execute --plot DIR``).
library_plots
    Figures of a motion library (``motionlib inspect --plot DIR``).
work_plots
    Figures of recorded crane work (``motionlib analyze --plot DIR``, 003 chapter 3).
meshes
    Triangle meshes of obstacles and capsules.
viewer
    Self-contained plotly HTML pages of plans, libraries and run logs.
live, live_scene
    The live view: a local web page (viser) to point and go while the closed loop runs.
dual_plots
    Figures of a dual-crane run: the internal force, the log's tracking and a top view.
dual_view
    The 3D HTML view of a dual-crane run: both cranes and the log, animated.
"""
