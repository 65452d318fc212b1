"""Plant identification from measured data (``exotune identify``): the joint-reflected plant
parameters J_m, B_m, K_s, J_j and K_c by least squares on the plant's equations (paper eq. (5)),
with the signals filtered by one state-variable filter so that no signal is differentiated
numerically.

``data``      reading and checking a log of the runtime's signals (CSV)
``estimate``  the state-variable filter, the regressions, their standard errors
``result``    the typed result (:class:`PlantEstimate`) and the design-file sections it gives
``validate``  the identified plant simulated on held-out data (NRMSE), residual tests, k-fold
``frf``       non-parametric frequency responses (H1, coherence) and the parameters read off them
``validresult`` the validation's typed results
``excite``    the excitation command for the rig (Schroeder-phased multisine, ``exotune excite``)
"""

from ..lazy import attach

__getattr__, __dir__, __all__ = attach(
    __name__,
    {
        "COLUMNS": "data",
        "MeasuredLog": "data",
        "read_log": "data",
        "log_from_columns": "data",
        "identify_plant": "estimate",
        "identify_file": "estimate",
        "ParameterEstimate": "result",
        "PlantEstimate": "result",
        "validate_plant": "validate",
        "Validation": "validresult",
        "Excitation": "excite",
        "schroeder_multisine": "excite",
        "write_excitation": "excite",
    },
)
