"""Free-model updating from a free-free test.

* :mod:`.fit` -- ``update_free_model``, ``UpdateOptions``, ``UpdateResult``, ``ModelFamily``;
* :mod:`.parameters` -- the parameter names each kind of free model can fit;
* :mod:`.check` -- the fit's own verdict (residual against the noise, resonances aligned);
* :mod:`.scaled_matrices` -- ``ScaledMatrixFamily``: stiffness and mass scales and loss factor of given matrices.
"""

from ..._lazy import attach

__getattr__, __dir__, __all__ = attach(
    __name__,
    {
        ".fit": ("update_free_model", "UpdateOptions", "UpdateResult", "ModelFamily"),
        ".scaled_matrices": ("ScaledMatrixFamily",),
    },
    submodules=("fit", "parameters", "check", "resonances", "scaled_matrices"),
)
