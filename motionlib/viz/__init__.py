"""Figures and the 3D viewer (the only subpackage that draws).

Modules
-------
plots
    Matplotlib figures of a plan (phase plane, joints, path), a run and a library's coverage.
meshes
    Triangle meshes of obstacles and capsules.
viewer
    Self-contained plotly HTML pages of plans, libraries and run logs.
"""
