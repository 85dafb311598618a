"""The estimation warm-up compiles exactly what the daemon's IMU path then runs: in a fresh
process, feeding samples decoded from the wire, poses and asking for the estimate after it
compiles nothing more (a compile on the event loop stalled it for a second on a cold
cache; the estimate's read-only arrays are a type of their own)."""

from __future__ import annotations

import textwrap

from tests.conftest import fresh_process_output

SCRIPT = textwrap.dedent(
    """
    import numpy as np
    from navd.config import NavdConfig
    from navd.wire import decode_sensor
    from navd.drivers.convert import sensor_message
    from navd.estimation import _madgwick_kernels, _ukf_kernels
    from navd.estimation.estimator import StateEstimator
    from navd.estimation.settings import EstimatorSettings
    from navd.estimation.warmup import warm_up
    from navd.lifecycle.messages import PoseMeasurement

    modules = (_madgwick_kernels, _ukf_kernels)
    kernels = [
        getattr(m, n) for m in modules for n in dir(m) if hasattr(getattr(m, n), "signatures")
    ]
    config = NavdConfig()
    warm_up(config.estimation)
    warmed = {f.__name__: len(f.signatures) for f in kernels}
    estimator = StateEstimator(EstimatorSettings.from_config(config))
    for i, line in enumerate([
        b'{"type":"imu","stamp":1.0,"angular_velocity":[0,0,0.1],"linear_acceleration":[0,0,9.8]}',
        b'{"type":"imu","stamp":1.01,"angular_velocity":[0,0,0.1],"linear_acceleration":[0,0,9.8],'
        b'"magnetic_field":[2e-5,0,-4e-5]}',
        b'{"type":"imu","angular_velocity":[1,2,3],"linear_acceleration":[0.5,0,9.7]}',
    ]):
        frame = decode_sensor("imu", line)
        estimator.add_imu(sensor_message(frame, "imu0", 1.0 + 0.01 * i, 1.02 + 0.01 * i))
    estimator.madgwick.window_mean(1.03, 0.05)
    estimator.add_pose(
        PoseMeasurement(stamp=1.04, received=1.05, source="lidar", x_m=0.1, y_m=0.0,
                        yaw_rad=0.01, covariance=np.diag([0.0025, 0.0025, 0.0004])),
        1.05,
    )
    estimator.add_pose(
        PoseMeasurement(stamp=1.06, received=1.07, source="lidar", x_m=0.11, y_m=0.0,
                        yaw_rad=0.01, covariance=np.diag([0.0025, 0.0025, 0.0004])),
        1.07,
    )
    assert estimator.estimate(1.08) is not None
    after = {f.__name__: len(f.signatures) for f in kernels}
    assert warmed["madgwick_ingest"] and warmed["imu_window_mean"], warmed
    assert warmed["ukf_step"] and warmed["propagate"], warmed
    assert after == warmed, (warmed, after)
    print("ok")
    """
)


def test_the_warm_up_leaves_nothing_for_the_first_samples_to_compile() -> None:
    assert fresh_process_output(SCRIPT) == "ok"
