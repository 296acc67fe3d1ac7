"""Figures and the 3D viewer (the only subpackage that draws).

Modules
-------
plan_plots
    Figures of a plan: phase plane (003 Fig. 4.1), joints against limits, the path in 3D.
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
