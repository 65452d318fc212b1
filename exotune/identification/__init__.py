"""Plant identification from measured data (``exotune identify``): the joint-reflected plant
parameters J_m, B_m, K_s, J_j and K_c by least squares on the plant's equations (paper eq. (1)),
with the signals filtered by one state-variable filter so that no signal is differentiated
numerically.

``data``      reading and checking a log of the runtime's signals (CSV)
``estimate``  the state-variable filter, the regressions, their standard errors
``result``    the typed result (:class:`PlantEstimate`) and the design-file sections it gives
"""

from .data import COLUMNS, MeasuredLog, log_from_columns, read_log
from .estimate import identify_file, identify_plant
from .result import ParameterEstimate, PlantEstimate

__all__ = ["COLUMNS", "MeasuredLog", "read_log", "log_from_columns", "identify_plant", "identify_file", "ParameterEstimate", "PlantEstimate"]
