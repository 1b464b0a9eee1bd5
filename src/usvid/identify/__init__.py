"""usvid.identify"""

# --- H6: estimators, d2c, servo identification, chaotic GA, turning-diameter fit ------------
from usvid.identify.cga import CGAResult, cga
from usvid.models.d2c import ContinuousTF, d2c, d2c_ss, split_delay
from usvid.identify.ls import (
    LeastSquares,
    NotFittedError,
    arx_regressors,
    arx_transfer_function,
    check_regression_data,
)
from usvid.identify.metrics import FitMetrics, fit_metrics, max_error, nrmse, r_squared, rmse
from usvid.identify.rls import RecursiveLeastSquares
from usvid.identify.servo import ServoIdentification, identify_second_order_servo
from usvid.identify.turning_diameter import (
    TurningDiameterFit,
    fit_turning_diameter,
    leave_one_out_rmse,
    load_turning_table,
)

__all__ = [
    "CGAResult", "ContinuousTF", "FitMetrics", "LeastSquares", "NotFittedError",
    "RecursiveLeastSquares", "ServoIdentification", "TurningDiameterFit", "arx_regressors",
    "arx_transfer_function", "cga",
    "check_regression_data", "d2c", "d2c_ss", "fit_metrics", "fit_turning_diameter",
    "identify_second_order_servo", "leave_one_out_rmse", "load_turning_table", "max_error",
    "nrmse", "r_squared", "rmse", "split_delay",
]
# --- end H6 ---------------------------------------------------------------------------------

# --- H7: model-kind fits (add below) --------------------------------------------------------
from usvid.identify.estimator import (  # noqa: E402
    IdentifiedModel,
    ModelEstimator,
    compare_kinds,
    fit,
    identify,
)
from usvid.identify.output_error import OEResult, refine_output_error  # noqa: E402
from usvid.identify.regressors import IdentificationWarning  # noqa: E402
from usvid.identify.validate import (  # noqa: E402
    cross_validate,
    validation_table,
    zigzag_check,
    zigzag_response,
)

__all__ += [
    "IdentificationWarning", "IdentifiedModel", "ModelEstimator", "OEResult", "compare_kinds",
    "cross_validate", "fit", "identify", "refine_output_error", "validation_table",
    "zigzag_check", "zigzag_response",
]
# --- end H7 ---------------------------------------------------------------------------------
