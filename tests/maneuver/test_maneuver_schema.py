"""The JSON Schema of the format: plain JSON, every field of every model in it, with the file's names."""

from __future__ import annotations

import json

import pytest

from planning.maneuver import maneuver_json_schema
from planning.maneuver.spec import (
    Adjust,
    Gait,
    Keyframe,
    Lean,
    Liftoff,
    LiftoffAdjust,
    Maneuver,
    MaximizeHeight,
    MinimizeTorque,
    Music,
    Touchdown,
    Weights,
)

MODELS = [
    Adjust,
    Gait,
    Keyframe,
    Lean,
    Liftoff,
    LiftoffAdjust,
    MaximizeHeight,
    MinimizeTorque,
    Music,
    Touchdown,
    Weights,
]


def test_schema_is_plain_json() -> None:
    schema = maneuver_json_schema()
    assert json.loads(json.dumps(schema)) == schema
    assert schema["$schema"].startswith("https://json-schema.org/")
    assert schema["type"] == "object" and schema["additionalProperties"] is False
    assert {"format", "name", "duration"} <= set(schema["required"])


@pytest.mark.parametrize("model", [Maneuver, *MODELS], ids=lambda m: m.__name__)
def test_schema_mentions_every_field_by_its_file_name(model) -> None:
    schema = maneuver_json_schema()
    node = schema if model is Maneuver else schema["$defs"][model.__name__]
    names = {f.alias or name for name, f in model.model_fields.items()}
    assert set(node["properties"]) == names
    assert node.get("additionalProperties") is False  # extra fields are refused


def test_schema_spells_out_the_choices() -> None:
    text = json.dumps(maneuver_json_schema())
    for word in (
        "footfall/maneuver@1",
        "trot",
        "walk",
        "pace",
        "bound",
        "pronk",
        "FL",
        "FR",
        "RL",
        "RR",
        "liftoff",
        "touchdown",
        "maximize_height",
        "lean",
        "^[a-z0-9]+(-[a-z0-9]+)*$",
    ):
        assert json.dumps(word)[1:-1] in text, word
    gait = maneuver_json_schema()["$defs"]["Gait"]
    assert "from" in gait["properties"] and "from_" not in gait["properties"]
    assert gait["properties"]["duty"]["exclusiveMaximum"] == 1.0


def test_music_is_optional_kept_and_checked(mk) -> None:
    """A maneuver keeps the tempo and first beat of its music; files without it load unchanged."""
    from planning.maneuver import ManeuverError, parse_maneuver
    from planning.maneuver.spec import MAX_BPM

    assert parse_maneuver(mk()).music is None
    m = parse_maneuver(mk(music={"bpm": 124, "offset": 0.35, "file": "song.wav"}))
    assert m.music is not None and (m.music.bpm, m.music.offset, m.music.file) == (124.0, 0.35, "song.wav")
    assert m.model_dump(by_alias=True, exclude_none=True)["music"] == {
        "bpm": 124.0,
        "offset": 0.35,
        "file": "song.wav",
    }
    with pytest.raises(ManeuverError) as e:
        parse_maneuver(mk(music={"bpm": MAX_BPM + 1, "offset": -0.1, "tempo": 3}))
    text = str(e.value)
    assert "music.bpm: must be at most 360" in text and "music.offset: must be at least 0" in text
    assert "music.tempo" in text
    assert maneuver_json_schema()["$defs"]["Music"]["properties"]["bpm"]["maximum"] == MAX_BPM
