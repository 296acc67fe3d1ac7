"""Recorded crane work: read it, split it into work-cycle states, measure it, replan it (003 chapter 3, Paper I).

Modules
-------
recording
    The import format of recorded crane work (CSV, run-log HDF5) and its strict reader.
segmentation
    A recording split into the work-cycle states of 003 Table 3.1.
work_stats
    Time distribution per state (003 Table 3.1) and simultaneous joint use (003 Figs. 3.3-3.4).
"""
