"""The Hong & Lee inverse method as the paper states it: estimation step (left inverse), identification step (right inverse).

* :mod:`.inverse` -- ``identify_joint``, ``InverseOptions``, ``InverseResult``, ``Reliability``;
* :mod:`.estimation` -- the estimation step's least-squares solvers (QR, SVD);
* :mod:`.condition` -- ``pencil_condition``, ``ConditionNumbers``.
"""

from ..._lazy import attach

__getattr__, __dir__, __all__ = attach(
    __name__,
    {
        ".inverse": ("identify_joint", "InverseOptions", "InverseResult", "Reliability"),
        ".condition": ("pencil_condition", "ConditionNumbers"),
    },
    submodules=("inverse", "estimation", "identification", "reliability", "condition"),
)
