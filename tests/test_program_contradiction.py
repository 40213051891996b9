"""A model whose factor rules out where the agent then sees an object: one line naming the model
and the object, exit 2, never a traceback (docs/design.md §4.8)."""

from __future__ import annotations

from fg_tea.cli.main import main

PROGRAM = '''
import fg_tea as fg

base = "factorised"


def model(scenario):
    m = fg.program_from_model(scenario, fg.load_model(base))

    @m.factor("teabag")
    def never_on_the_pantry_shelf(teabag):
        return 0.0 if teabag.name == "pantry_shelf" else 1.0

    return m
'''


def test_a_world_the_model_rules_out_ends_in_one_line(tmp_path, capsys):
    program = tmp_path / "never.py"
    program.write_text(PROGRAM)
    # world seed 0 of the fake house puts the teabag on the pantry shelf
    code = main(["run", "--model", str(program), "--env", "fake", "--no-video", "--seed", "0",
                 "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1, err
    assert err[0].startswith(f"fg-tea: error: {program}: the model rules out what the agent saw: the teabag "
                             "at pantry_shelf")
