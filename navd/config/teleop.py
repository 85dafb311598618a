"""Driving by hand: what an operator's velocity commands may do."""

from __future__ import annotations

from pydantic import Field

from navd.config.fields import Section

__all__ = ["TeleopConfig"]


class TeleopConfig(Section):
    """Manual driving (``navd teleop``, the operator page's joystick, a viewer's /cmd_vel).

    An operator's command passes the same safety gate as the planner's (speed limits, the
    collision guard, stale sensors, lost localization) and, when the operator's commands stop
    coming, the chassis stops within ``safety.reaction_timeout_s`` (the deadman). While an
    operator drives, the navigator is paused; its goal resumes ``resume_after_s`` after the
    last command, planned afresh from where the robot then is.
    """

    enabled: bool = Field(True, description="accept velocity commands from operators")
    max_linear_speed_mps: float = Field(
        0.5,
        gt=0,
        le=10,
        description="[m/s] top manual speed either way (robot.max_linear_speed_mps still caps)",
    )
    max_angular_speed_radps: float = Field(
        1.0,
        gt=0,
        le=20,
        description="[rad/s] top manual yaw rate (robot.max_angular_speed_radps still caps)",
    )
    resume_after_s: float = Field(
        2.0,
        gt=0,
        le=3600,
        description="[s] a goal paused by manual driving resumes this long after the last "
        "operator command",
    )
