"""usvid.identify: estimators of every model kind (equation error, RLS, output error, zig-zag
replay), servo identification, discrete-to-continuous conversion, the chaotic GA and the
turning-diameter fit, validation.

Public names load their module on first use (PEP 562): importing a light module of the package
(``usvid.identify.defaults``, read by ``usvid identify --help``) does not load the estimators.
"""

from usvid.lazy import lazy_names

#: Public name -> the module that defines it.
_WHERE = {
    "CGAResult": "usvid.identify.cga",
    "ContinuousTF": "usvid.models.d2c",
    "EquationErrorFit": "usvid.identify.equation_error",
    "FitMetrics": "usvid.identify.metrics",
    "IdentificationWarning": "usvid.identify.series",
    "IdentifiedModel": "usvid.identify.estimator",
    "LeastSquares": "usvid.identify.ls",
    "ModelEstimator": "usvid.identify.estimator",
    "NotFittedError": "usvid.identify.ls",
    "OEResult": "usvid.identify.output_error",
    "RecursiveLeastSquares": "usvid.identify.rls",
    "Series": "usvid.identify.series",
    "ServoIdentification": "usvid.identify.servo",
    "TrialValidation": "usvid.identify.validation",
    "TurningDiameterFit": "usvid.identify.turning_diameter",
    "ValidationResult": "usvid.identify.validation",
    "arx_regressors": "usvid.identify.ls",
    "arx_transfer_function": "usvid.identify.ls",
    "cga": "usvid.identify.cga",
    "check_regression_data": "usvid.identify.ls",
    "compare_kinds": "usvid.identify.estimator",
    "cross_validate": "usvid.identify.validate",
    "d2c": "usvid.models.d2c",
    "d2c_ss": "usvid.models.d2c",
    "fit": "usvid.identify.estimator",
    "fit_equation_error": "usvid.identify.equation_error",
    "fit_metrics": "usvid.identify.metrics",
    "fit_turning_diameter": "usvid.identify.turning_diameter",
    "identify": "usvid.identify.estimator",
    "identify_second_order_servo": "usvid.identify.servo",
    "leave_one_out_rmse": "usvid.identify.turning_diameter",
    "load_turning_table": "usvid.identify.turning_diameter",
    "max_error": "usvid.identify.metrics",
    "nrmse": "usvid.identify.metrics",
    "r_squared": "usvid.identify.metrics",
    "refine_output_error": "usvid.identify.output_error",
    "rmse": "usvid.identify.metrics",
    "split_delay": "usvid.models.d2c",
    "trial_series": "usvid.identify.series",
    "validate_model": "usvid.identify.validation",
    "validate_trial": "usvid.identify.validation",
    "zigzag_response": "usvid.identify.validate",
}

__all__ = sorted(_WHERE)


__getattr__, __dir__ = lazy_names(__name__, _WHERE)
