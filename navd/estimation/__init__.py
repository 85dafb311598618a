"""State estimation: Madgwick IMU filter, 9-state UKF, event and state queues, GPS/compass.

No asyncio here: plain computation driven by the lifecycle layer (``node.EstimationNode``).
"""

from navd.estimation.errors import EstimationError, GeoError
from navd.estimation.estimator import Localization, StateEstimator
from navd.estimation.geo import GeoFrame

__all__ = ["EstimationError", "GeoError", "GeoFrame", "Localization", "StateEstimator"]
