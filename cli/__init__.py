"""The ``motionlib`` command-line application (a thin layer over the library)."""
