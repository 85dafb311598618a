"""State estimation: Madgwick IMU filter, 9-state UKF, event and state queues, GPS/compass.

No asyncio here: plain computation driven by the lifecycle layer (``node.EstimationNode``).
"""

from navd.estimation.bearing import bearing_to_yaw
from navd.estimation.errors import EstimationError, GeoError
from navd.estimation.estimator import Localization, StateEstimator
from navd.estimation.geo import GeoFrame
from navd.estimation.history import Insert
from navd.estimation.madgwick import GRAVITY_MPS2, MadgwickFilter
from navd.estimation.motion_model import (
    STATE_SIZE,
    TH,
    ProcessNoise,
    Row,
    evaluate_rows,
    transition_matrix,
)
from navd.estimation.node import EstimationNode
from navd.estimation.settings import EstimatorSettings
from navd.estimation.ukf import FloatArray, Measurement, PoseUkf, StepOutcome, UkfSettings
from navd.estimation.warmup import warm_up

__all__ = [
    "GRAVITY_MPS2",
    "STATE_SIZE",
    "TH",
    "EstimationError",
    "EstimationNode",
    "EstimatorSettings",
    "FloatArray",
    "GeoError",
    "GeoFrame",
    "Insert",
    "Localization",
    "MadgwickFilter",
    "Measurement",
    "PoseUkf",
    "ProcessNoise",
    "Row",
    "StateEstimator",
    "StepOutcome",
    "UkfSettings",
    "bearing_to_yaw",
    "evaluate_rows",
    "transition_matrix",
    "warm_up",
]
