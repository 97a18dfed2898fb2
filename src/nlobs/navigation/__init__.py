"""GNSS/INS navigation: SO(3) utilities, flight and sensor generation, observers and the EKF baseline."""
