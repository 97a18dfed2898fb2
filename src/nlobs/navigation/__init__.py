"""GNSS/INS navigation (seed 001, Sec. 5): SO(3) utilities, flight and sensor generation,
the interconnected observer (22)/(24), the EKF baseline, the sampled-data runner and plots.

Conventions are stated in :mod:`nlobs.navigation.base`.
"""
