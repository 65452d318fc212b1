"""exotune.model: the physical model and the controller, as objects (docs/method.md#physical-model).

``plant``       the joint-reflected plant (:class:`Plant`) and the compliance-pair algebra (paper §II)
``shaping``     SEA and double compliance shaping: design parameters → controller gains (paper §IV)
``controller``  the controller structure the runtime executes (:class:`ControllerStructure`)
``humans``      human and environment families
``interop``     python-control and numpy conventions at the library's edge (descending coefficients)
"""

from ..lazy import attach

__getattr__, __dir__, __all__ = attach(
    __name__,
    {
        "Plant": "plant",
        "DesignParams": "shaping",
        "Gains": "shaping",
        "double_compliance_shaping": "shaping",
        "ControllerStructure": "controller",
        "build_controller": "controller",
        "HumanFamily": "humans",
        "EnvModel": "humans",
        "ascending": "interop",
        "descending": "interop",
    },
)
