"""Motion libraries: many planned trajectories in one HDF5 file, and selection among them.

Modules
-------
spec
    :class:`~.spec.LibrarySpec`: which motions a library holds (YAML, read strictly).
build
    :func:`~.build.build_library`: parallel (process pool or Dask), resumable, crash-safe build.
store
    :class:`~.store.Library` (reading) and :class:`~.store.LibraryWriter` (the HDF5 format).
selection
    Trajectory selection for an operator's target (003 eqs. 5.3-5.7).
commands
    Command-set files: names bound to targets, points or regions and their utility (003 section 5.1.1).
"""
