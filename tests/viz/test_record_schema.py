"""navd's JSON in a recording carries real JSON schemas: each is one Foxglove and Lichtblick
read (by their parser's rule, ``viewer_schema_rule``), every recorded message validates
against its topic's schema (checked by the ``jsonschema`` library, read back with the MCAP
reference reader), and a message that is not what its schema says is refused by it."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import jsonschema
import pytest
from mcap.reader import make_reader

from navd.config import parse_config
from navd.lifecycle.messages import GoalStatus, LaserScan, Message
from navd.viz.record_codec import INFO, INPUTS, OUTPUTS, decode, encode, topic_of
from navd.viz.record_schema import SESSION_SCHEMA, message_schema, topic_schema
from navd.viz.recording_writer import RecordingWriter, WriterSettings, recording_files
from navd.viz.settings import RecorderSettings
from tests.viz.test_record_codec import SAMPLES
from tests.viz.viewer_schema_rule import unreadable

HEADER = {"began_s": 12.0, "into_run_s": 3.5, "had_map": False, "seeded_pose": True}


def _validator(schema: dict[str, Any]) -> jsonschema.Draft202012Validator:
    jsonschema.Draft202012Validator.check_schema(schema)
    return jsonschema.Draft202012Validator(schema)


@pytest.mark.parametrize("kind", INPUTS + OUTPUTS + INFO, ids=lambda k: k.__name__)
def test_every_recorded_type_has_a_schema_the_viewers_read(kind: type[Message]) -> None:
    schema = message_schema(kind)
    _validator(schema)
    assert unreadable(schema) == []
    assert schema["title"] == f"navd.{kind.__name__}"
    assert "stamp" in schema["properties"]  # a float: named, and a number
    assert set(schema["required"]) <= set(kind.__dataclass_fields__)


def test_the_session_header_has_a_schema_the_viewers_read() -> None:
    assert unreadable(SESSION_SCHEMA) == []


@pytest.mark.parametrize("message", SAMPLES, ids=lambda m: type(m).__name__)
def test_each_recorded_message_is_valid_against_its_schema(message: Message) -> None:
    topic = topic_of(type(message))
    assert topic is not None
    named = topic_schema(topic)
    assert named is not None
    _validator(named[1]).validate(json.loads(encode(message)))


def test_a_message_unlike_its_schema_is_refused() -> None:
    scan = next(m for m in SAMPLES if isinstance(m, LaserScan))
    good = json.loads(encode(scan))
    validator = _validator(message_schema(LaserScan))
    assert validator.is_valid(good)
    missing = {k: v for k, v in good.items() if k != "device_id"}
    not_an_array = {**good, "ranges": [1.0, 2.0]}
    a_word = {**good, "range_max": "far"}
    spelled_in_place = {**good, "range_max": "Infinity"}  # the codec lists it in not_finite
    for bad in (missing, not_an_array, a_word, spelled_in_place):
        assert not validator.is_valid(bad)


def test_a_number_json_cannot_hold_is_listed_apart_and_read_back() -> None:
    status = GoalStatus(stamp=1.0, received=1.0, goal_id="g", state="active")  # NaN ETA
    recorded = json.loads(encode(status))
    assert "eta_s" not in recorded
    assert {"field": "eta_s", "value": "NaN"} in recorded["not_finite"]
    _validator(message_schema(GoalStatus)).validate(recorded)
    back = decode("/navd/out/GoalStatus", encode(status))
    assert isinstance(back, GoalStatus) and math.isnan(back.eta_s)
    # a recording made before the list: the number spelled in place still reads back
    old = {k: v for k, v in recorded.items() if k != "not_finite"} | {
        "eta_s": "NaN",
        "distance_remaining_m": "NaN",
    }
    again = decode("/navd/out/GoalStatus", json.dumps(old).encode())
    assert isinstance(again, GoalStatus) and math.isnan(again.eta_s)


def test_the_config_as_recorded_follows_its_schema_which_the_viewers_read() -> None:
    config = parse_config({"tcp": {"token": "s3cret-token-of-sixteen"}, "robot": {"name": "r2"}})
    recorded = json.loads(RecorderSettings.from_config(config).config_json)
    assert recorded["tcp"]["token"] != "s3cret-token-of-sixteen"  # a marker, still a string
    named = topic_schema("/navd/config")
    assert named is not None
    name, schema = named
    assert name == "navd.Config" and unreadable(schema) == []
    validator = _validator(schema)
    validator.validate(recorded)
    assert "robot" in schema["properties"] and "name" in schema["properties"]["robot"]["properties"]
    assert not validator.is_valid({**recorded, "robot": {**recorded["robot"], "name": 7}})


def test_a_recording_read_by_the_reference_reader_has_a_schema_for_every_json_channel(
    tmp_path: Path,
) -> None:
    config = RecorderSettings.from_config(parse_config({})).config_json
    writer = RecordingWriter(WriterSettings(tmp_path, 10**9, 10**10, 0.02), config, HEADER, print)
    for i, message in enumerate(SAMPLES):
        topic = topic_of(type(message))
        assert topic is not None
        writer.put(topic, message, i * 1_000_000)
    writer.close()
    (file,) = recording_files(tmp_path)
    checked: set[str] = set()
    with file.open("rb") as stream:
        for schema, channel, record in make_reader(stream).iter_messages():
            if channel.message_encoding != "json":
                continue
            assert schema is not None and schema.encoding == "jsonschema" and schema.data
            body = json.loads(schema.data)
            assert unreadable(body) == [], channel.topic
            _validator(body).validate(json.loads(record.data))
            checked.add(schema.name)
    expected = {f"navd.{type(m).__name__}" for m in SAMPLES} | {"navd.Config", "navd.Session"}
    assert checked == expected
