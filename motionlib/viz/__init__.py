"""Figures and the 3D viewer (the only subpackage that draws).

Modules
-------
plan_plots
    Figures of a plan: phase plane (003 Fig. 4.1), joints against limits, the path in 3D.
meshes
    Triangle meshes of obstacles and capsules.
viewer
    Self-contained plotly HTML pages of plans, libraries and run logs.
"""
