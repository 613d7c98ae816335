"""Objects: particles -> ball candidates in 3D, this frame.

- ``clustering.py``: weighted EM with ISODATA split / merge / discard (paper section III-F).
- ``explain.py``: every object must explain a colour blob (stereo ghosts dropped, positions refined).
- ``discs.py``: the depth of a ball whose blob is shared with other balls.
"""
