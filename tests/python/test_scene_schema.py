"""docs/scene.schema.json against the scene-file parser (scenarios/src/scenes/file/), through the
command-line tool (NONHOLO_CLI, set by CTest).

- Every example in examples/scenes/ validates, and runs.
- Each invalid document of tests/test_scene_file.cpp (reproduced here) that JSON Schema can
  express is rejected by the schema, and by the command line (exit 1, the parser's message).
- Each one it cannot express (PARSER_ONLY, with the reason) validates, and the command line
  refuses it: what only the parser catches is listed, not assumed.
- Drift: a scene generated from the schema with every key it allows (each optional key at the
  schema's default) runs, and gives the same summary as the same scene without the defaults
  written out; the parser's key lists and type names in its source equal the schema's.
"""
import copy
import json
import os
import pathlib
import re

import pytest

from support import cli, without_timings

ROOT = pathlib.Path(__file__).resolve().parents[2]
SCHEMA_PATH = ROOT / "docs" / "scene.schema.json"
PARSER_SOURCES = sorted((ROOT / "scenarios" / "src" / "scenes" / "file").glob("*.cpp"))
EXAMPLES = sorted((ROOT / "examples" / "scenes").glob("*.json"))


def strict_json(text):
    """json.loads without Python's extensions (NaN, Infinity): what the parser reads."""
    def refuse(name):
        raise ValueError(f"{name} is not JSON")
    return json.loads(text, parse_constant=refuse)


SCHEMA = json.loads(SCHEMA_PATH.read_text())


@pytest.fixture(scope="module")
def validator():
    jsonschema = pytest.importorskip("jsonschema", reason="Debian's python3-jsonschema validates the schema")
    jsonschema.Draft202012Validator.check_schema(SCHEMA)
    return jsonschema.Draft202012Validator(SCHEMA)


def run_file(tmp_path, text, *args, name="scene.json"):
    path = tmp_path / name
    path.write_text(text)
    return path, cli("run", str(path), "--t-end", "0.1", *args)


def expect_refused(done, path, fragment):
    assert done.returncode == 1, (done.returncode, done.stdout, done.stderr)
    assert f"{path}: " in done.stderr, done.stderr  # names the file
    assert fragment in done.stderr, done.stderr


# --- The documents of tests/test_scene_file.cpp ---------------------------------------------------

BODY = '{"mass": 1, "inertia": 1, "position": [0, 0]}'
PLANAR = BODY
RIGID = '{"type": "rigid", "inertia": [1, 2, 3]}'  # about a fixed point
FLAT2 = '{"type": "rigid", "mass": 1, "inertia": [1, 1, 1], "translation": 2, "position": [0, 0]}'


def rigid3(position, extra=""):
    return '{"type": "rigid", "mass": 1, "inertia": [1, 1, 1], "translation": 3, "position": ' + position + extra + "}"


def scene(bodies, rest=""):
    return '{"bodies": [' + bodies + "]" + (", " + rest if rest else "") + "}"


# (what, document, a fragment of the parser's message): the schema rejects each, and so does the
# command line.
SCHEMA_REJECTS = [
    ("no bodies", '{"bodies": []}', "bodies: missing (an array of at least one body is required)"),
    ("planar mass missing", '{"bodies": [{"inertia": 1, "position": [0, 0]}]}', "bodies[0].mass: missing (a number is required)"),
    ("negative mass", '{"bodies": [{"mass": -1, "inertia": 1, "position": [0, 0]}]}', "bodies[0].mass: must be positive, got -1"),
    ("mass as text", '{"bodies": [{"mass": "heavy", "inertia": 1, "position": [0, 0]}]}',
     "bodies[0].mass: expected a number, got string"),
    ("position of 3", '{"bodies": [{"mass": 1, "inertia": 1, "position": [0, 0, 0]}]}',
     "bodies[0].position: expected 2 numbers, got 3 entries"),
    ("number overflow", '{"bodies": [{"mass": 1, "inertia": 1, "position": [0, 1e999]}]}',
     "line 1, column 55: the number 1e999 is not a finite double"),
    ("unknown body key", '{"bodies": [{"mas": 1, "inertia": 1, "position": [0, 0]}]}',
     "bodies[0]: unknown key 'mas' (known: heading, inertia, mass, name, position, turn_rate, type, velocity)"),
    ("unknown constraint", scene(BODY, '"constraints": [{"type": "wheel", "body": 0}]'),
     "constraints[0].type: unknown constraint type 'wheel'"),
    ("unknown coupling", scene(BODY + "," + BODY, '"couplings": [{"type": "rope", "bodies": [0, 1]}]'),
     "couplings[0].type: unknown coupling type 'rope' (known: torsional_spring)"),
    ("spring on one body", scene(BODY + "," + BODY, '"couplings": [{"type": "torsional_spring", "bodies": [0, 0], "stiffness": 1}]'),
     "couplings[0].bodies: a body cannot be joined to itself"),
    ("thrust without body", scene(BODY, '"forces": [{"type": "thrust"}]'), "forces[0].body: missing"),
    ("dt zero", scene(BODY, '"dt": 0'), "dt: must be positive"),
    ("nested 100 deep", '{"bodies": [' + BODY + '], "constraints": ' + "[" * 100 + "]" * 100 + "}",
     "nested deeper than 64 levels (a scene file needs 5)"),
    # rigid bodies
    ("body type soft", scene('{"type": "soft", "inertia": 1}'), "bodies[0].type: unknown body type 'soft' (known: planar, rigid)"),
    ("heading on rigid", scene('{"type": "rigid", "inertia": [1, 2, 3], "heading": 0}'),
     "bodies[0]: key 'heading' belongs to planar bodies; this body is rigid"),
    ("angular_velocity on planar", scene('{"mass": 1, "inertia": 1, "position": [0, 0], "angular_velocity": [0, 0, 1]}'),
     "bodies[0]: key 'angular_velocity' belongs to rigid bodies; this body is planar"),
    ("unknown rigid key", scene('{"type": "rigid", "inertia": [1, 2, 3], "spin": 1}'), "bodies[0]: unknown key 'spin'"),
    ("quaternion of 3", scene('{"type": "rigid", "inertia": [1, 2, 3], "orientation": [1, 0, 0]}'),
     "bodies[0].orientation: expected 4 numbers, got 3 entries"),
    ("orientation as text", scene('{"type": "rigid", "inertia": [1, 2, 3], "orientation": "up"}'),
     "bodies[0].orientation: expected a unit quaternion [w, x, y, z]"),
    ("zero axis", scene('{"type": "rigid", "inertia": [1, 2, 3], "orientation": {"axis": [0, 0, 0], "angle": 1}}'),
     "bodies[0].orientation.axis: must not be zero"),
    ("axis without angle", scene('{"type": "rigid", "inertia": [1, 2, 3], "orientation": {"axis": [0, 0, 1]}}'),
     "bodies[0].orientation.angle: missing (a number is required)"),
    ("rigid inertia missing", scene('{"type": "rigid"}'), "bodies[0].inertia: missing (3 principal moments"),
    ("negative moment", scene('{"type": "rigid", "inertia": [1, -2, 3]}'),
     "bodies[0].inertia: rigid body 0: inertia is not positive definite"),
    ("inertia of 2", scene('{"type": "rigid", "inertia": [1, 2]}'), "bodies[0].inertia: expected 3 principal moments"),
    ("inertia a number", scene('{"type": "rigid", "inertia": 1}'), "got number"),
    ("inertia row of 2", scene('{"type": "rigid", "inertia": [[1, 0, 0], [0, 1], [0, 0, 1]]}'),
     "bodies[0].inertia[1]: expected a row of 3 numbers (the inertia is a 3x3 array), got 2 entries"),
    ("inertia entry text", scene('{"type": "rigid", "inertia": [[1, 0, 0], [0, 1, "x"], [0, 0, 1]]}'),
     "bodies[0].inertia[1][2]: expected a number, got string"),
    ("translation 1", scene('{"type": "rigid", "inertia": [1, 1, 1], "translation": 1}'),
     "bodies[0].translation: must be 0 (a fixed point), 2 (the centre moves in a horizontal plane) or 3 (free), got 1"),
    ("translation text", scene('{"type": "rigid", "inertia": [1, 1, 1], "translation": "free"}'),
     "bodies[0].translation: expected 0, 2 or 3, got string"),
    ("free body without mass", scene('{"type": "rigid", "inertia": [1, 1, 1], "translation": 3, "position": [0, 0, 1]}'),
     "bodies[0].mass: missing (a number is required)"),
    ("free body without position", scene('{"type": "rigid", "mass": 1, "inertia": [1, 1, 1], "translation": 3}'),
     "bodies[0].position: missing (3 numbers are required)"),
    ("fixed point with position", scene('{"type": "rigid", "inertia": [1, 1, 1], "position": [0, 0]}'),
     "bodies[0].position: the body's centre is fixed (translation 0)"),
    ("radius zero", scene(RIGID, '"constraints": [{"type": "rolling_ball", "body": 0, "radius": 0}]'),
     "constraints[0].radius: must be positive, got 0"),
    ("body axis missing", scene(RIGID, '"constraints": [{"type": "body_axis", "body": 0}]'),
     "constraints[0].axis: missing (3 numbers are required)"),
    ("body axis zero", scene(RIGID, '"constraints": [{"type": "body_axis", "body": 0, "axis": [0, 0, 0]}]'),
     "constraints[0]: body-axis constraint: axis (0 0 0) must be finite and nonzero"),
    ("unknown force", scene(RIGID, '"forces": [{"type": "wind"}]'), "forces[0].type: unknown force type 'wind'"),
    ("gravity without a free body", scene(RIGID, '"forces": [{"type": "gravity"}]'),
     'forces[0]: gravity acts on rigid bodies that move freely in 3-D ("translation": 3), and the file has none'),
    ("gravity twice", scene(rigid3("[0, 0, 0]"), '"forces": [{"type": "gravity"}, {"type": "gravity", "g": 1}]'),
     "forces[1]: gravity is given twice (first in forces[0])"),
    ("body torque a number", scene(RIGID, '"forces": [{"type": "body_torque", "body": 0, "value": 1}]'),
     "forces[0].value: expected 3 numbers, got number"),
    # Beyond tests/test_scene_file.cpp: the builder's ranges, which the schema states.
    ("mass below 2^-970", '{"bodies": [{"mass": 1e-320, "inertia": 1, "position": [0, 0]}]}', "mass m = 9.99989e-321 is below"),
    ("rod length squared underflows",
     scene(PLANAR + ', {"mass": 1, "inertia": 1, "position": [1e-150, 0]}', '"constraints": [{"type": "rod", "bodies": [0, 1], "length": 1e-150}]'),
     "squared is 1e-300, outside"),
    ("unknown top-level key", scene(BODY, '"gravity": 9.81'), "(top level): unknown key 'gravity'"),
]

# Refused by the parser or the model builder only: JSON Schema sees one value at a time (no
# comparison between two values, no reference from an index to the body it names), sees the
# document only after a JSON reader has parsed it (duplicate keys gone, 1.0 and 1 the same
# number), and never the file. Each validates against the schema; the command line refuses it.
PARSER_ONLY = [
    # an index out of range: the number of bodies is another value
    ("knife edge on body 3 of 1", scene(BODY, '"constraints": [{"type": "knife_edge", "body": 3}]'),
     "constraints[0].body: body 3 does not exist (the file has 1 bodies, 0 to 0)"),
    ("ball on body 2 of 1", scene(RIGID, '"constraints": [{"type": "rolling_ball", "body": 2, "radius": 1}]'),
     "constraints[0].body: body 2 does not exist (the file has 1 bodies, 0 to 0)"),
    ("rod to body 5 of 2", scene(RIGID + "," + RIGID, '"constraints": [{"type": "rod", "bodies": [0, 5], "length": 1}]'),
     "constraints[0].bodies[1]: body 5 does not exist (the file has 2 bodies, 0 to 1)"),
    # a body index written with a fraction: the same number as 1 to JSON Schema
    ("body index 0.0", scene(BODY, '"constraints": [{"type": "knife_edge", "body": 0.0}]'),
     "constraints[0].body: expected a body index, got number"),
    # holonomic constraints that do not hold at the start: positions of several bodies
    ("open hitch", scene(BODY + "," + BODY, '"constraints": [{"type": "hitch", "bodies": [0, 1], "rear": 0.5, "front": 0.5}]'),
     "the hitch is open at the start: its two points are 1 apart"),
    ("rod not at its length (3-D)", scene(rigid3("[0, 0, 1]") + "," + rigid3("[3, 0, 1]"), '"constraints": [{"type": "rod", "bodies": [0, 1], "length": 2}]'),
     "constraints[0]: the rod is not at its length at the start: the centres of bodies 0 and 1 are 3 apart"),
    ("rod not at its length (2-D)", scene(PLANAR + "," + FLAT2, '"constraints": [{"type": "rod", "bodies": [1, 0], "length": 2}]'),
     "constraints[0]: the rod is not at its length at the start: the centres of bodies 1 and 0 are 0 apart"),
    ("ball above the ground", scene(rigid3("[0, 0, 2]"), '"constraints": [{"type": "rolling_ball", "body": 0, "radius": 1}]'),
     "constraints[0]: the ball is not on the ground at the start: its centre is at height 2, its radius is 1"),
    ("disk above the ground",
     scene(rigid3("[0, 0, 0.5]", ', "orientation": {"axis": [1, 0, 0], "angle": 0.5235987755982988}'),
           '"constraints": [{"type": "rolling_disk", "body": 0, "radius": 2}]'),
     "constraints[0]: the disk is not on the ground at the start: its centre is at height 0.5"),
    ("disk lying flat", scene(rigid3("[0, 0, 0]"), '"constraints": [{"type": "rolling_disk", "body": 0, "radius": 1}]'),
     "constraints[0]: the disk lies flat at the start"),
    # a unit quaternion: a relation between four numbers
    ("quaternion norm 1.00005", scene('{"type": "rigid", "inertia": [1, 2, 3], "orientation": [1, 0, 0, 0.01]}'),
     "bodies[0].orientation: the quaternion [w, x, y, z] has norm 1.0000499987500624"),
    # a symmetric positive definite inertia; a mass block's condition number; a length against
    # the body's radius of gyration: relations between values
    ("inertia not symmetric", scene('{"type": "rigid", "inertia": [[1, 0, 0], [0.5, 2, 0], [0, 0, 3]]}'),
     "bodies[0].inertia: rigid body 0: inertia is not symmetric: I(1, 0) = 0.5 but I(0, 1) = 0"),
    ("inertia not definite", scene('{"type": "rigid", "inertia": [[1, 2, 0], [2, 1, 0], [0, 0, 3]]}'),
     "bodies[0].inertia: rigid body 0: inertia is not positive definite"),
    ("planar mass block ill-conditioned", scene(BODY + ', {"mass": 1e17, "inertia": 1, "position": [1, 0]}'),
     "bodies[1]: body 1 (x1, y1, theta1): mass block is too ill-conditioned"),
    ("rigid mass block ill-conditioned", scene('{"type": "rigid", "mass": 1e13, "inertia": [1, 1, 1], "translation": 2, "position": [0, 0]}'),
     "bodies[0]: rigid body 0: mass block is too ill-conditioned"),
    ("principal moments 1, 10, 100", scene('{"type": "rigid", "inertia": [1, 10, 100]}'),
     "bodies[0].inertia: rigid body 0: principal moments 1, 10, 100 break the triangle inequality (1 + 10 < 100)"),
    ("principal moments 1e13 apart", scene('{"type": "rigid", "inertia": [1, 1, 1e-13]}'),
     "bodies[0].inertia: rigid body 0: mass block is too ill-conditioned"),
    ("offset 1e308", scene(BODY, '"constraints": [{"type": "knife_edge", "body": 0, "offset": 1e308}]'),
     "constraints[0]: knife edge on body 0: offset a = 1e+308 is 1e+308 times the body's radius of gyration"),
    # an element on the wrong kind of body: the body an index names
    ("disk on a planar-centred body", scene(FLAT2, '"constraints": [{"type": "rolling_disk", "body": 0, "radius": 1}]'),
     "constraints[0]: rolling disk: body 0 has translation 2"),
    ("ball on a planar body", scene(PLANAR, '"constraints": [{"type": "rolling_ball", "body": 0, "radius": 1}]'),
     "constraints[0]: rolling ball: body 0 is not a 3-D rigid body"),
    ("knife edge on a rigid body", scene(RIGID, '"constraints": [{"type": "knife_edge", "body": 0}]'),
     "constraints[0]: knife edge: body 0 is a 3-D rigid body; this element acts on planar bodies"),
    ("rod between 2-D and 3-D centres", scene(FLAT2 + "," + rigid3("[1, 0, 1]"), '"constraints": [{"type": "rod", "bodies": [0, 1], "length": 1}]'),
     "constraints[0]: rod: body 0's centre moves in 2-D, body 1's in 3-D"),
    ("body torque on a planar body", scene(PLANAR, '"forces": [{"type": "body_torque", "body": 0, "value": [0, 0, 1]}]'),
     "forces[0]: body torque: body 0 is not a 3-D rigid body"),
    ("body force on a fixed point", scene(RIGID, '"forces": [{"type": "body_force", "body": 0, "value": [1, 0, 0]}]'),
     "forces[0]: body force on body 0: its centre is fixed (translation 0)"),
    ("thrust on a rigid body", scene(RIGID, '"forces": [{"type": "thrust", "body": 0, "value": 1}]'),
     "forces[0]: thrust: body 0 is a 3-D rigid body"),
    ("spring on rigid bodies", scene(RIGID + "," + RIGID, '"couplings": [{"type": "torsional_spring", "bodies": [0, 1], "stiffness": 1}]'),
     "couplings[0]: torsional spring: body 0 is a 3-D rigid body"),
    # dependent one-forms at the start: the rows of several elements together
    ("two knife edges on one body",
     scene(BODY + ', {"mass": 1, "inertia": 1, "position": [-1, 0]}',
           '"constraints": [{"type": "knife_edge", "body": 0}, {"type": "hitch", "bodies": [0, 1], "rear": 0.5, "front": 0.5}, '
           '{"type": "knife_edge", "body": 1}, {"type": "knife_edge", "body": 1}]'),
     "constraints[3] (knife_edge on body 1)"),
    ("two equal body axes",
     scene(RIGID, '"constraints": [{"type": "body_axis", "body": 0, "axis": [0, 0, 1]}, '
                  '{"type": "body_axis", "body": 0, "axis": [0, 0, 2]}]'),
     "constraints[1] (body_axis on body 0)"),
    # duplicate keys: a JSON reader keeps one of them before the schema sees the object
    ("duplicate key", '{"bodies": [{"mass": 1, "mass": 2, "inertia": 1, "position": [0, 0]}]}',
     "bodies[0]: duplicate key 'mass' (each key may appear once in an object)"),
]


@pytest.mark.parametrize("example", EXAMPLES, ids=lambda p: p.name)
def test_every_example_validates_and_runs(example, validator):
    validator.validate(strict_json(example.read_text()))
    done = cli("run", str(example), "--t-end", "0.05")
    assert done.returncode == 0, done.stderr
    assert done.stdout.split()[-1] == "status=ok", done.stdout


@pytest.mark.parametrize("what,text,fragment", SCHEMA_REJECTS, ids=[c[0] for c in SCHEMA_REJECTS])
def test_the_schema_rejects_what_the_parser_rejects(what, text, fragment, validator, tmp_path):
    assert not validator.is_valid(strict_json(text)), what
    path, done = run_file(tmp_path, text)
    expect_refused(done, path, fragment)


@pytest.mark.parametrize("what,text,fragment", PARSER_ONLY, ids=[c[0] for c in PARSER_ONLY])
def test_what_only_the_parser_catches_is_refused_by_the_command_line(what, text, fragment, validator, tmp_path):
    errors = [e.message for e in validator.iter_errors(strict_json(text))]
    assert not errors, f"{what}: the schema rejects it, so it belongs in SCHEMA_REJECTS: {errors}"
    path, done = run_file(tmp_path, text)
    expect_refused(done, path, fragment)
    assert done.stdout == "", "refused before the first step: no summary line"


def test_text_that_is_not_json_is_refused(tmp_path):
    text = '{\n  "bodies": [\n    {"mass": 1,, }\n  ]\n}'
    with pytest.raises(ValueError):
        strict_json(text)
    path, done = run_file(tmp_path, text)
    expect_refused(done, path, "line 3, column 16: syntax error")
    # NaN is not JSON (Python's reader would take it; the schema could not refuse it).
    path, done = run_file(tmp_path, scene(BODY, '"dt": NaN'))
    expect_refused(done, path, "syntax error")


def test_what_is_not_a_document_is_refused(tmp_path):
    directory = tmp_path / "dir.json"
    directory.mkdir()
    done = cli("run", str(directory))
    expect_refused(done, directory, "is a directory; a scene file must be a regular file")
    fifo = tmp_path / "fifo.json"
    os.mkfifo(fifo)
    done = cli("run", str(fifo))
    expect_refused(done, fifo, "is a FIFO (named pipe); a scene file must be a regular file")
    big = tmp_path / "big.json"
    with open(big, "wb") as f:
        f.truncate(64 * 2**20 + 1)  # sparse: no disk used
    done = cli("run", str(big))
    expect_refused(done, big, "is 67108865 bytes; a scene file may be at most 67108864 bytes (64 MiB)")
    missing = tmp_path / "missing.json"
    expect_refused(cli("run", str(missing)), missing, "cannot be read")


# --- Drift: every key the schema allows is one the parser takes, with the same defaults -----------

# Every element type, each body kind and translation; keys left out where the schema has a default.
MINIMAL = {
    "bodies": [
        {"mass": 2, "inertia": 1.5, "position": [0, 0], "velocity": [1, 0]},
        {"mass": 1, "inertia": 0.8, "position": [-1.3, 0]},
        {"type": "rigid", "inertia": [[1, 0, 0.5], [0, 2, 0.5], [0.5, 0.5, 3]], "any_inertia": True,
         "angular_velocity": [1, 0.6, 0]},
        {"type": "rigid", "inertia": [1, 2, 3], "orientation": {"axis": [1, 1, 0], "angle": 0.8}},
        {"type": "rigid", "mass": 1, "inertia": [0.3, 0.4, 0.5], "translation": 2, "position": [5, 0],
         "angular_velocity": [1, -0.5, 2]},
        {"type": "rigid", "mass": 1, "inertia": [0.25, 0.25, 0.5], "translation": 3,
         "orientation": {"axis": [1, 0, 0], "angle": 1.2}, "position": [10, 0, 0.9320390859672263],
         "angular_velocity": [0.3, 0, 5], "velocity": [-5, -0.27961172579016785, 0.10870732634300208]},
        {"type": "rigid", "mass": 1, "inertia": [0.4, 0.4, 0.4], "translation": 3, "position": [20, 0, 0.5],
         "angular_velocity": [0, 1, 0]},
        {"type": "rigid", "mass": 2, "inertia": [[0.5, 0.1, 0], [0.1, 0.6, 0], [0, 0, 0.7]], "translation": 3,
         "orientation": [1, 0, 0, 0], "position": [21.2, 1.6, 0.5], "angular_velocity": [0.5, 0, -1]},
    ],
    "constraints": [
        {"type": "knife_edge", "body": 0, "offset": 0.3},
        {"type": "knife_edge", "body": 1},
        {"type": "hitch", "bodies": [0, 1], "rear": 0.6, "front": 0.7},
        {"type": "body_axis", "body": 2, "axis": [0, 0, 1]},
        {"type": "space_axis", "body": 3},
        {"type": "rolling_ball", "body": 4, "radius": 1},
        {"type": "rolling_disk", "body": 5, "radius": 1},
        {"type": "rolling_ball", "body": 6, "radius": 0.5},
        {"type": "rolling_ball", "body": 7, "radius": 0.5},
        {"type": "rod", "bodies": [7, 6], "length": 2},
    ],
    "couplings": [{"type": "torsional_spring", "bodies": [0, 1], "stiffness": 0.5}],
    "forces": [
        {"type": "thrust", "body": 0, "value": 0.2},
        {"type": "torque", "body": 0, "amplitude": 0.3, "omega": 0.5},
        {"type": "gravity"},
        {"type": "body_torque", "body": 4, "amplitude": [0, 0, 0.2], "omega": 2},
        {"type": "body_force", "body": 6, "value": [0.1, 0, 0]},
    ],
}


def kind_schemas():
    """The object kinds of the schema: name -> its schema (the top level as "(top level)")."""
    kinds = {"(top level)": SCHEMA}
    kinds.update({name: d for name, d in SCHEMA["$defs"].items() if d.get("additionalProperties") is False})
    return kinds


def allowed_keys(kind):
    keys = set(kind.get("properties", {}))
    for branch in kind.get("allOf", []):
        keys |= set(branch.get("then", {}).get("properties", {}))
    return keys


def instances(doc):
    """(kind name, object) for every object of a scene document."""
    yield "(top level)", doc
    for b in doc["bodies"]:
        yield ("rigid_body" if b.get("type") == "rigid" else "planar_body"), b
        if isinstance(b.get("orientation"), dict):
            yield "axis_angle", b["orientation"]
    for key in ("constraints", "couplings", "forces"):
        for c in doc.get(key, []):
            yield c["type"], c


def with_every_key(doc):
    """doc with every optional key written out: the schema's default, or a comment for strings."""
    jsonschema = pytest.importorskip("jsonschema")
    doc = copy.deepcopy(doc)
    kinds = kind_schemas()
    for n, (name, obj) in enumerate(list(instances(doc))):
        kind = kinds[name]
        properties = dict(kind.get("properties", {}))
        for branch in kind.get("allOf", []):  # the conditional branches that apply to obj
            if "if" in branch and jsonschema.Draft202012Validator({**branch["if"], "$defs": SCHEMA["$defs"]}).is_valid(obj):
                properties.update(branch["then"].get("properties", {}))
        for key, sub in properties.items():
            if key in obj or not isinstance(sub, dict):
                continue
            if "default" in sub:
                obj[key] = copy.deepcopy(sub["default"])
            elif sub.get("type") == "string":
                obj[key] = f"{name} {n}"
    return doc


def test_the_generated_maximal_scene_uses_every_key_and_runs_as_the_minimal_one(validator, tmp_path):
    maximal = with_every_key(MINIMAL)
    validator.validate(MINIMAL)
    validator.validate(maximal)
    used = {}
    for name, obj in instances(maximal):
        used.setdefault(name, set()).update(obj)
    for name, kind in kind_schemas().items():
        assert used.get(name, set()) == allowed_keys(kind), (
            f"{name}: the generated scene uses {sorted(used.get(name, set()))}, the schema allows "
            f"{sorted(allowed_keys(kind))}: give MINIMAL an instance that exercises the new key")
    for group in ("constraint", "coupling", "force"):
        assert set(SCHEMA["$defs"][group]["properties"]["type"]["enum"]) <= set(used), group
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    lines = []
    for directory, doc in (("a", MINIMAL), ("b", maximal)):
        path = tmp_path / directory / "scene.json"
        path.write_text(json.dumps(doc, indent=1))
        done = cli("run", str(path), "--t-end", "0.05")
        assert done.returncode == 0, done.stderr
        assert done.stdout.split()[-1] == "status=ok", done.stdout
        lines.append(" ".join(w for w in without_timings(done.stdout.strip()).split() if not w.startswith("scene=")))
    assert lines[0] == lines[1], "a default of the schema is not the parser's"


def parser_source():
    """The parser's code: the files of scenarios/src/scenes/file/ together."""
    assert PARSER_SOURCES, "no parser sources found: update PARSER_SOURCES"
    return "\n".join(path.read_text() for path in PARSER_SOURCES)


def parser_key_sets():
    """The key lists of the parser: every brace list of string literals it checks keys against."""
    source = parser_source()
    lists = re.findall(r'keys\([^;]*?\{((?:\s*"[a-z_]+"\s*,?)+)\}\)', source)
    lists += re.findall(r'k(?:Planar|Rigid)Keys\{((?:\s*"[a-z_]+"\s*,?)+)\}', source)
    return [set(re.findall(r'"([a-z_]+)"', group)) for group in lists]


def test_the_parsers_keys_and_type_names_are_the_schemas():
    parser = parser_key_sets()
    assert len(parser) >= 10, "the parser's key lists were not found: update parser_key_sets()"
    schema = [allowed_keys(kind) for kind in kind_schemas().values()]
    for keys in parser:
        assert keys in schema, f"the parser checks keys {sorted(keys)}; no object of the schema allows exactly these"
    assert set().union(*parser) == set().union(*schema)
    known = dict(re.findall(r"unknown (body|constraint|coupling|force) type '\" \+ type \+\s*\"' \(known: ([a-z_, ]+)\)",
                            parser_source()))
    assert set(known) == {"body", "constraint", "coupling", "force"}, known
    enum = {"constraint": SCHEMA["$defs"]["constraint"]["properties"]["type"]["enum"],
            "coupling": SCHEMA["$defs"]["coupling"]["properties"]["type"]["enum"],
            "force": SCHEMA["$defs"]["force"]["properties"]["type"]["enum"],
            "body": ["planar", "rigid"]}
    for group, names in known.items():
        assert sorted(names.split(", ")) == sorted(enum[group]), group
