"""The one unit conversion of hbm: speeds are given in rpm, computed in rad/s."""

import numpy as np

__all__ = ["RPM_TO_RAD_S"]

#: rad/s per rpm.
RPM_TO_RAD_S = 2.0 * np.pi / 60.0
