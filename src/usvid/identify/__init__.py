"""usvid.identify: estimators of every model kind (equation error, RLS, output error, zig-zag
replay), servo identification, discrete-to-continuous conversion, the chaotic GA and the
turning-diameter fit, validation."""

from usvid.identify.cga import CGAResult, cga
from usvid.identify.equation_error import EquationErrorFit, fit_equation_error
from usvid.identify.estimator import (
    IdentifiedModel,
    ModelEstimator,
    compare_kinds,
    fit,
    identify,
)
from usvid.identify.ls import (
    LeastSquares,
    NotFittedError,
    arx_regressors,
    arx_transfer_function,
    check_regression_data,
)
from usvid.identify.metrics import FitMetrics, fit_metrics, max_error, nrmse, r_squared, rmse
from usvid.identify.output_error import OEResult, refine_output_error
from usvid.identify.rls import RecursiveLeastSquares
from usvid.identify.series import IdentificationWarning, Series, trial_series
from usvid.identify.servo import ServoIdentification, identify_second_order_servo
from usvid.identify.turning_diameter import (
    TurningDiameterFit,
    fit_turning_diameter,
    leave_one_out_rmse,
    load_turning_table,
)
from usvid.identify.validate import cross_validate, zigzag_response
from usvid.identify.validation import (
    TrialValidation,
    ValidationResult,
    validate_model,
    validate_trial,
)
from usvid.models.d2c import ContinuousTF, d2c, d2c_ss, split_delay

__all__ = [
    "CGAResult", "ContinuousTF", "EquationErrorFit", "FitMetrics", "IdentificationWarning",
    "IdentifiedModel", "LeastSquares", "ModelEstimator", "NotFittedError", "OEResult",
    "RecursiveLeastSquares", "Series", "ServoIdentification", "TrialValidation",
    "TurningDiameterFit", "ValidationResult",
    "arx_regressors", "arx_transfer_function", "cga", "check_regression_data", "compare_kinds",
    "cross_validate", "d2c", "d2c_ss", "fit", "fit_equation_error", "fit_metrics",
    "fit_turning_diameter", "identify", "identify_second_order_servo", "leave_one_out_rmse",
    "load_turning_table", "max_error", "nrmse", "r_squared", "refine_output_error", "rmse",
    "split_delay", "trial_series", "validate_model", "validate_trial", "zigzag_response",
]
