"""Sinks: where each frame's result goes (tracks CSV, a recording of the frames, the rerun viewer, the network).

A sink receives a ``FrameResult`` per frame (``write``) and is closed once; it never reaches back.
"""
