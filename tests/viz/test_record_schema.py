"""navd's JSON in a recording carries real JSON schemas: every recorded message validates
against its topic's schema (checked by the ``jsonschema`` library, read back with the MCAP
reference reader), and a message that is not what its schema says is refused by it."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import jsonschema
import pytest
from mcap.reader import make_reader

from navd.config import parse_config
from navd.lifecycle.messages import LaserScan, Message
from navd.viz.record_codec import CONFIG_TOPIC, INFO, INPUTS, OUTPUTS, encode, topic_of
from navd.viz.record_schema import message_schema, topic_schema
from navd.viz.recording_writer import RecordingWriter, WriterSettings, recording_files
from navd.viz.settings import RecorderSettings
from tests.viz.test_record_codec import SAMPLES

HEADER = {"began_s": 12.0, "into_run_s": 3.5, "had_map": False, "seeded_pose": True}


def _validator(schema: dict[str, Any]) -> jsonschema.Draft202012Validator:
    jsonschema.Draft202012Validator.check_schema(schema)
    return jsonschema.Draft202012Validator(schema)


@pytest.mark.parametrize("kind", INPUTS + OUTPUTS + INFO, ids=lambda k: k.__name__)
def test_every_recorded_type_has_a_valid_schema_naming_each_field(kind: type[Message]) -> None:
    schema = message_schema(kind)
    _validator(schema)
    assert schema["title"] == f"navd.{kind.__name__}"
    assert set(schema["required"]) == set(kind.__dataclass_fields__)


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
    wrong_dtype = {**good, "ranges": {**good["ranges"], "dtype": "<f8"}}
    missing = {k: v for k, v in good.items() if k != "range_max"}
    unknown = {**good, "rangez": 3.0}
    a_word = {**good, "range_max": "far"}
    for bad in (wrong_dtype, missing, unknown, a_word):
        assert not validator.is_valid(bad)
    assert validator.is_valid({**good, "range_max": "Infinity"})  # as the codec spells it


def test_the_config_as_recorded_is_valid_against_the_config_schema() -> None:
    config = parse_config({"tcp": {"token": "s3cret-token-of-sixteen"}, "robot": {"name": "r2"}})
    recorded = json.loads(RecorderSettings.from_config(config).config_json)
    assert recorded["tcp"]["token"] != "s3cret-token-of-sixteen"  # a marker, still a string
    named = topic_schema(CONFIG_TOPIC)
    assert named is not None
    validator = _validator(named[1])
    validator.validate(recorded)
    assert not validator.is_valid({**recorded, "robot": {**recorded["robot"], "radius_m": "x"}})


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
            _validator(json.loads(schema.data)).validate(json.loads(record.data))
            checked.add(schema.name)
    expected = {f"navd.{type(m).__name__}" for m in SAMPLES} | {"navd.Config", "navd.Session"}
    assert checked == expected
