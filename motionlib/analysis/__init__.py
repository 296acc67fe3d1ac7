"""Recorded crane work: read it, split it into work-cycle states, measure it, replan it (003 chapter 3, Paper I).

Modules
-------
recording
    The import format of recorded crane work (CSV, run-log HDF5) and its strict reader.
column_map
    How to read a machine's recording: column names, units, a numeric grapple, duplicates and gaps.
signals
    Window-averaged velocities, the noise of a recording, joint speeds against the crane's limits.
segmentation
    A recording split into the work-cycle states of 003 Table 3.1.
work_stats
    Time distribution per state (003 Table 3.1) and simultaneous joint use (003 Figs. 3.3-3.4).
work_analysis
    ``analyze_recording``: the whole analysis of one recording (what ``motionlib analyze`` prints).
replan
    ``replan_recording``: every recorded move replanned along its path and freely (003 Paper I).
"""
