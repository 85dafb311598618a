"""docs/rooms.md lists exactly the modules of every room: each folder of the package has one
table there, whose rows name each of its modules (and subpackages) once, and nothing else."""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PACKAGE = ROOT / "navd"
SOURCES = (".py", ".js", ".html", ".css")
HEADER = re.compile(r"^\| Module \((navd/(?:[a-z_]+/)*)\) \|")
ROW = re.compile(r"^\| `([^`]+)` \|")


def _tables() -> dict[str, list[str]]:
    """Every module table in docs/: the folder it names, and the names in its rows."""
    tables: dict[str, list[str]] = {}
    for doc in sorted((ROOT / "docs").glob("*.md")):
        folder: str | None = None
        for line in doc.read_text(encoding="utf-8").splitlines():
            header = HEADER.match(line)
            if header:
                folder = header.group(1)
                assert folder not in tables, f"{doc.name}: a second table of {folder}"
                tables[folder] = []
                continue
            if folder is None:
                continue
            row = ROW.match(line)
            if row:
                tables[folder].append(row.group(1))
            elif not line.startswith("|"):
                folder = None
    return tables


def _folders() -> dict[str, set[str]]:
    """Every folder of the package with sources: its modules, and its subpackages as NAME/."""
    folders: dict[str, set[str]] = {}
    for folder in [PACKAGE, *sorted(p for p in PACKAGE.rglob("*") if p.is_dir())]:
        names = {f.name for f in folder.iterdir() if f.is_file() and f.suffix in SOURCES}
        if not names:
            continue
        if folder != PACKAGE:
            names |= {
                f"{sub.name}/"
                for sub in folder.iterdir()
                if sub.is_dir() and any(s.suffix in SOURCES for s in sub.iterdir())
            }
        folders[folder.relative_to(ROOT).as_posix() + "/"] = names
    return folders


def test_every_folder_of_the_package_has_one_table_naming_exactly_its_modules() -> None:
    tables, folders = _tables(), _folders()
    assert sorted(tables) == sorted(folders), "a folder without a table, or a table of none"
    for folder, names in folders.items():
        rows = tables[folder]
        assert len(rows) == len(set(rows)), f"{folder}: a module listed twice"
        assert set(rows) == names, (
            f"{folder}: missing {sorted(names - set(rows))}, gone {sorted(set(rows) - names)}"
        )
