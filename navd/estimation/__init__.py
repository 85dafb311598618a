"""State estimation: Madgwick IMU filter, 9-state UKF, event and state queues, GPS/compass.

No asyncio here: plain computation driven by the lifecycle layer.
"""

from navd.estimation.errors import EstimationError

__all__ = ["EstimationError"]
