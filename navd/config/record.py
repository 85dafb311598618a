"""Recording what the daemon hears and decides, for replay and for Foxglove."""

from __future__ import annotations

from pydantic import Field, model_validator

from navd.config.fields import Section, restart

__all__ = ["RecordConfig"]


class RecordConfig(Section):
    """Sessions recorded to MCAP files: every input as the daemon received it (sensor data,
    control requests, config changes) and its outputs (poses, routes, wheel commands, goal
    progress, safety holds). ``navd run --record DIR`` or a control client's ``record``
    request starts it; ``navd replay FILE_OR_DIR`` plays it back through the whole pipeline.
    """

    enabled: bool = Field(False, **restart("record from start-up"))
    dir: str = Field("recordings", min_length=1, description="folder the MCAP files go to")
    max_file_mb: float = Field(
        100.0, ge=1, le=100_000, description="[MB] a file this large is closed and a new one begun"
    )
    budget_mb: float = Field(
        2000.0,
        ge=1,
        le=10_000_000,
        description="[MB] the folder's recordings are kept under this; the oldest files go first",
    )
    flush_period_s: float = Field(
        1.0,
        gt=0,
        le=60,
        description="[s] data is on disk (a whole chunk, readable after a crash) this often",
    )
    map_period_s: float = Field(
        5.0, gt=0, le=3600, description="[s] least time between two recorded maps (the largest)"
    )

    @model_validator(mode="after")
    def _file_within_budget(self) -> RecordConfig:
        if self.max_file_mb > self.budget_mb:
            raise ValueError(
                f"record.max_file_mb ({self.max_file_mb}) must not exceed record.budget_mb "
                f"({self.budget_mb}): one file would overrun the budget"
            )
        return self
