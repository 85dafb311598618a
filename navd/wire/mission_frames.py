"""A mission as a control client sends it: its steps (``MissionStepSpec``), rounds and
failure policy (``MissionFrame``), and the commands that pause, resume, cancel or continue
it (``MissionControlFrame``); docs/missions.md describes each step's fields."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from navd.wire.base import DEVICE_ID_PATTERN, Coordinate, Frame
from navd.wire.errors import MissionDocumentError

__all__ = [
    "MAX_MISSION_STEPS",
    "MissionControlFrame",
    "MissionFrame",
    "MissionPolicy",
    "MissionStepSpec",
    "mission_from_document",
]

MAX_MISSION_STEPS = 1000
MissionPolicy = Literal["skip", "retry", "abort"]


class MissionStepSpec(BaseModel):
    """One step: ``kind`` and its fields (see docs/missions.md)."""

    model_config = ConfigDict(strict=True, extra="forbid", frozen=True, allow_inf_nan=False)

    kind: Literal[
        "goto", "goto_gps", "wait", "pause", "approach", "beacon", "gate", "visit_beacons"
    ]
    x: Coordinate | None = None
    y: Coordinate | None = None
    yaw: float | None = Field(None, ge=-10.0, le=10.0)
    latitude: float | None = Field(None, ge=-90, le=90)
    longitude: float | None = Field(None, ge=-180, le=180)
    seconds: float | None = Field(None, ge=0, le=86400)
    message: str = Field("", max_length=500)
    stop_distance: float = Field(0.3, ge=0, le=10)
    speed: float | None = Field(None, gt=0, le=10)
    on_failure: MissionPolicy | None = None
    retries: int | None = Field(None, ge=0, le=100)
    beacon: str | None = Field(None, pattern=DEVICE_ID_PATTERN)
    beacons: list[Annotated[str, Field(pattern=DEVICE_ID_PATTERN)]] | None = Field(
        None, max_length=MAX_MISSION_STEPS
    )

    @model_validator(mode="after")
    def _fields_of_the_kind(self) -> MissionStepSpec:
        needs = {
            "goto": ("x", "y"),
            "approach": ("x", "y"),
            "goto_gps": ("latitude", "longitude"),
            "wait": ("seconds",),
            "pause": (),
            "beacon": ("beacon",),
            "gate": ("beacons",),
            "visit_beacons": (),
        }[self.kind]
        missing = [name for name in needs if getattr(self, name) is None]
        if missing:
            raise ValueError(f"a {self.kind} step needs {' and '.join(missing)}")
        if self.kind == "gate" and (self.beacons is None or len(set(self.beacons)) != 2):
            raise ValueError(f"a gate step needs two different beacons, got {self.beacons}")
        return self


class MissionFrame(Frame):
    """Run a mission: ``steps`` in order, ``rounds`` times (``"forever"`` or 0 for a patrol
    that runs until cancelled); a failed step does ``on_failure`` (skip, retry ``retries``
    times, or abort) unless the step says otherwise."""

    type: Literal["mission"] = "mission"
    mission_id: str | None = Field(None, pattern=DEVICE_ID_PATTERN)
    name: str = Field("mission", min_length=1, max_length=100)
    rounds: Annotated[int, Field(ge=0, le=100000)] = 1
    on_failure: MissionPolicy = "abort"
    retries: int = Field(2, ge=0, le=100)
    steps: list[MissionStepSpec] = Field(min_length=1, max_length=MAX_MISSION_STEPS)

    @model_validator(mode="before")
    @classmethod
    def _rounds_forever(cls, data: Any) -> Any:
        if isinstance(data, dict) and data.get("rounds") == "forever":
            return {**data, "rounds": 0}
        return data


class MissionControlFrame(Frame):
    """Pause, resume or cancel the running mission, or say "continue" to a pause step."""

    type: Literal["mission_control"] = "mission_control"
    action: Literal["pause", "resume", "cancel", "continue"]


def mission_from_document(
    document: Mapping[str, Any], mission_id: str | None = None
) -> MissionFrame:
    """A mission file's table (TOML or JSON, already parsed) as the frame that runs it: the
    same fields as a ``mission`` frame, its ``type`` optional; ``mission_id`` replaces the
    file's.

    Raises:
        MissionDocumentError: every field that is wrong, each named by its path.
    """
    data = {key: value for key, value in document.items() if key != "type"}
    if mission_id is not None:
        data["mission_id"] = mission_id
    try:
        return MissionFrame.model_validate(data)
    except ValidationError as err:
        problems = [
            f"{'.'.join(str(p) for p in e['loc']) or 'mission'}: {e['msg']}"
            for e in err.errors(include_url=False)
        ]
        raise MissionDocumentError(problems) from err
