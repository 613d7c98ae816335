"""Evidence: what one camera's image says about a target's balls, computed once per frame and camera.

- ``colour.py``: HSV masks and their integral images; learning a target's range from a region.
- ``blobs.py``: colour blobs of a mask (connected components, or the paper's histogram maxima).
"""
