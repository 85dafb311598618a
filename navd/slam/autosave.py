"""The map kept through a crash: while it grows the SLAM module saves it every
``slam.autosave_period_s`` as ``map_dir/autosave`` (the same atomic save as any other); a start
that finds one goes on mapping from it, the first scan finding the robot on it, as a
``slam.load_map`` start does; a clean stop removes it (it was only ever for a crash)."""

from __future__ import annotations

from pathlib import Path

from navd.slam.map_io import saved_files

__all__ = ["AUTOSAVE_NAME", "autosave_path", "remove_autosave"]

AUTOSAVE_NAME = "autosave"


def autosave_path(map_dir: str) -> Path:
    """The autosave's YAML in ``map_dir`` (it may not exist)."""
    return Path(map_dir) / f"{AUTOSAVE_NAME}.yaml"


def remove_autosave(map_dir: str) -> list[Path]:
    """Remove the autosave's files from ``map_dir``; the paths removed."""
    yaml_path = autosave_path(map_dir)
    if not yaml_path.exists():
        return []
    removed = []
    for path in reversed(saved_files(yaml_path)):  # the YAML last: never one naming nothing
        try:
            path.unlink()
            removed.append(path)
        except FileNotFoundError:
            continue
    return removed
