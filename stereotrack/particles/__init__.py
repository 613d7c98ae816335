"""Particles: the mixed CONDENSATION + abductive population of each target (paper Table I).

- ``likelihood.py``: how well a particle's projections match the evidence (paper eq. 14).
- ``proposal.py``: abductive particles on the viewing rays of blobs and where rays cross.
- ``resampling.py``: systematic resampling of a weighted set.
- ``population.py``: the population's step (resample, move, propose, weigh).
"""
