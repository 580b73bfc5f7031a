"""Fits of direct (step-sine) test data: material and Zener fits, master curves, amplitude and preload dependence.

* :mod:`.material_fit` -- ``fit_material`` (+ :mod:`.material_static`, :mod:`.modulus_per_line`);
* :mod:`.zener_fit` -- ``fit_zener``;
* :mod:`.master_curve` -- ``build_master_curve`` (+ :mod:`.shift_estimation`, :mod:`.shift_laws`, :mod:`.master_zener`);
* :mod:`.amplitude_dependence` -- ``fit_kraus``, ``fit_kraus_loss``, ``fit_preload``;
* :mod:`.unit_slip` -- ``find_unit_slips`` (a test whose level is a unit factor off its neighbours').
"""

from ..._lazy import attach

__getattr__, __dir__, __all__ = attach(
    __name__,
    {
        ".material_fit": ("fit_material", "MaterialFit", "static_estimate", "StaticEstimate",
                          "complex_modulus_per_line", "ComplexModulus", "fit_zener", "ZenerFit"),
        ".master_curve": ("build_master_curve", "MasterCurve", "TemperatureCurve"),
        ".shift_laws": ("fit_wlf", "fit_arrhenius", "WLFFit", "ArrheniusFit"),
        ".amplitude_dependence": ("fit_kraus", "KrausFit", "fit_kraus_loss", "KrausLossFit", "fit_preload", "PreloadFit"),
        ".unit_slip": ("find_unit_slips", "UnitSlip"),
    },
    submodules=("material_fit", "material_static", "modulus_per_line", "zener_fit", "master_curve", "master_zener",
                "shift_estimation", "shift_laws", "amplitude_dependence", "unit_slip"),
)
