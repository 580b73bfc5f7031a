"""The receptance-coupling estimator (the default inverse method) and its parts.

* :mod:`.coupling` -- ``identify_joint_coupling``; :mod:`.options` -- ``CouplingOptions``; :mod:`.coupling_result` -- ``CouplingResult``;
* :mod:`.spline_fit` -- ``fit_joint_spline``: every term a few B-splines in log f, fitted to all lines at once;
* :mod:`.units_check`, :mod:`.junk_lines`, :mod:`.model_check` -- the data checks (units, junk lines, the free model per band);
* :mod:`.coupling_lines` -- the weighted per-line least squares;
* :mod:`.column_calibration` -- force-calibration error per excitation column;
* :mod:`.frf_variance` -- the FRF variance model (coherence, relative, none);
* :mod:`.smoothing` -- P-spline smoothing over frequency;
* :mod:`.structured_model`, :mod:`.structured_fit`, :mod:`.structured_select` -- the structured joint model.
"""

from ..._lazy import attach

__getattr__, __dir__, __all__ = attach(
    __name__,
    {
        ".coupling": ("identify_joint_coupling",),
        ".options": ("CouplingOptions",),
        ".coupling_result": ("CouplingResult",),
        ".spline_fit": ("fit_joint_spline", "JointSplineFit"),
        ".coupling_lines": ("coupling_per_line", "LineEstimates"),
        ".smoothing": ("smooth_series", "SmoothedSeries"),
    },
    submodules=("coupling", "options", "coupling_result", "spline_fit", "units_check", "junk_lines", "model_check", "coupling_lines", "column_calibration", "frf_variance", "smoothing",
                "structured_model", "structured_fit", "structured_select"),
)
