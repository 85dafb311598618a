"""The VDA 5050 2.1.0 JSON schemas, from ../shared/standards beside the clone (or
$NAVD_STANDARDS): a validator per topic; tests that need them skip, saying why, without."""

from __future__ import annotations

import json
import os
from functools import cache
from pathlib import Path
from typing import Any

import pytest

REPO = Path(__file__).resolve().parents[2]


@cache
def _validator(topic: str) -> Any:
    jsonschema = pytest.importorskip("jsonschema", reason="jsonschema (a dev dependency) missing")
    root = Path(os.environ.get("NAVD_STANDARDS", REPO.parent / "shared" / "standards"))
    path = root / "vda5050" / "2.1.0" / f"{topic}.schema"
    if not path.is_file():
        pytest.skip(
            f"the VDA 5050 schema {path} is absent: it lives in ../shared/standards beside the "
            "clone (CI has it); set NAVD_STANDARDS to point elsewhere"
        )
    schema = json.loads(path.read_text(encoding="utf-8"))
    kind = jsonschema.validators.validator_for(schema)  # the draft the schema names
    return kind(schema, format_checker=kind.FORMAT_CHECKER)


def check(topic: str, message: dict[str, Any]) -> None:
    """Fail with every problem if ``message`` breaks the schema of ``topic``."""
    problems = [
        f"{'/'.join(map(str, e.absolute_path)) or '(top)'}: {e.message}"
        for e in _validator(topic).iter_errors(message)
    ]
    assert not problems, f"{topic} breaks its schema:\n" + "\n".join(problems)
