"""Do the published JSON Schemas (docs/schemas/) say what the validator accepts?

The schemas are recorded from the parsers as they read the bundled files
(fg_tea.common.schemas, docs/design.md §1.3). Checked: the committed schemas are what the parsers
read today; every bundled file validates against its schema; a misspelt key, a probability over
1 and a wrong type fail in the schema as they fail in ``fg-tea validate`` (one line, exit 2).
"""

from __future__ import annotations

import importlib.util
import json
import re
import sys
import tomllib
from pathlib import Path

import pytest

jsonschema = pytest.importorskip("jsonschema")

ROOT = Path(__file__).resolve().parents[1]
SCHEMAS = ROOT / "docs" / "schemas"


def _tool():
    spec = importlib.util.spec_from_file_location("_make_schemas", ROOT / "docs" / "tools" / "make_schemas.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module


TOOL = _tool()


def _load(path: Path):
    return tomllib.loads(path.read_text()) if path.suffix == ".toml" else json.loads(path.read_text())


def _validator(kind: str):
    schema = json.loads((SCHEMAS / f"{kind}.schema.json").read_text())
    jsonschema.Draft202012Validator.check_schema(schema)
    return jsonschema.Draft202012Validator(schema)


def test_committed_schemas_are_what_the_parsers_read():
    assert TOOL.main(["--check"]) == 0, "run python docs/tools/make_schemas.py"


@pytest.mark.parametrize("kind", sorted(TOOL.SOURCES))
def test_every_bundled_file_validates(kind):
    validator = _validator(kind)
    files = TOOL._files(kind)
    assert files
    for path in files:
        data = _load(path)
        if kind == "model" and "extends" in data:
            continue  # a model's schema describes the merged document; the parts are partial
        errors = [e.message for e in validator.iter_errors(data)]
        assert errors == [], f"{path.name}: {errors[:3]}"


def _validate(path: Path, capsys) -> tuple[int, str]:
    from fg_tea.cli.main import main

    status = main(["validate", str(path)])
    return status, capsys.readouterr().err


CASES = {  # kind, file, edit of its text, the validator's words
    "typo": ("scenario", "scenarios/default_apartment.json",
             lambda t: t.replace('"objects"', '"objcts"', 1), "unknown field"),
    "probability": ("camera", "cameras/visibility.toml",
                    lambda t: re.sub(r"max_probability = [\d.]+", "max_probability = 1.5", t), "outside [0, 1]"),
    "type": ("world", "scenarios/worlds/independent.json",
             lambda t: re.sub(r'"description": "[^"]*"', '"description": 3', t, count=1), "expected a string"),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_a_fault_fails_in_the_schema_as_in_the_validator(case, tmp_path, capsys):
    kind, rel, edit, words = CASES[case]
    text = edit((ROOT / rel).read_text())
    assert text != (ROOT / rel).read_text()
    path = tmp_path / Path(rel).name
    path.write_text(text)
    assert list(_validator(kind).iter_errors(_load(path))), "the schema accepts it"
    status, err = _validate(path, capsys)
    assert status == 2 and words in err and len(err.strip().splitlines()) == 1, err
