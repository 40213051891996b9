"""Every numeric flag has a range whose endpoints work (fuzzers grown to the flags that broke).

Each ``fg-tea`` option typed by ``integer(lo, hi)`` or ``number(lo, hi)`` accepts its endpoints and
refuses one step beyond them in one line with exit 2 (quick: parsing only). The rendering options,
where an endpoint once crashed (``--third-person-pitch 90``), also run ``fg-tea preview`` at both
endpoints (slow).
"""

from __future__ import annotations

import argparse

import pytest

from fg_tea.cli.main import build_parser, main


def _bounded(parser: argparse.ArgumentParser):
    """(command, option, type) of every bounded numeric option of every subcommand."""
    for action in parser._actions:  # noqa: SLF001
        if isinstance(action, argparse._SubParsersAction):  # noqa: SLF001
            for name, sub in action.choices.items():
                for a in sub._actions:  # noqa: SLF001
                    if getattr(a.type, "bounds", None) is not None and a.option_strings:
                        yield name, a.option_strings[-1], a.type


BOUNDED = sorted({(c, o): t for c, o, t in _bounded(build_parser())}.items())


def _endpoints(bounds):
    lo, hi, *opens = bounds
    lo_open, hi_open = (opens + [False, False])[:2]
    inside, outside = [], []
    step = 1 if isinstance(lo, int) and not opens else 1e-9 * max(1.0, abs(hi or 1))
    if not lo_open:
        inside.append(lo)
    outside.append(lo - step if not lo_open else lo)
    if hi is not None:
        if not hi_open:
            inside.append(hi)
        outside.append(hi + step if not hi_open else hi)
    return inside, outside


def test_there_are_bounded_flags_in_every_command_that_takes_numbers():
    commands = {c for (c, _), _ in BOUNDED}
    assert {"run", "render", "preview", "compare", "house"} <= commands, commands


@pytest.mark.parametrize("command, option", [key for key, _ in BOUNDED])
def test_a_numeric_flag_accepts_its_endpoints_and_refuses_beyond(command, option, capsys):
    kind = dict(BOUNDED)[(command, option)]
    inside, outside = _endpoints(kind.bounds)
    for value in inside:
        assert kind(repr(value)) == value
    for value in outside:
        with pytest.raises(SystemExit) as done:
            build_parser().parse_args([command, option, repr(value)])
        assert done.value.code == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and option in err[0], err


RENDER = sorted({o for (c, o), _ in BOUNDED if c == "preview" and o not in ("--seed", "--workers")})


@pytest.mark.slow
@pytest.mark.parametrize("option", RENDER)
def test_preview_renders_at_both_endpoints_of_every_rendering_option(option, tmp_path, capsys):
    """An endpoint renders, or (with the other options at their defaults) is refused in one line
    naming the clash (e.g. the default inset cannot fit a 64-pixel-high frame); never a crash."""
    kind = dict(BOUNDED)[("preview", option)]
    inside, _ = _endpoints(kind.bounds)
    rendered = 0
    for i, value in enumerate(inside):
        out = tmp_path / f"p{i}.png"
        status = main(["preview", option, repr(value), "--out", str(out)])
        err = capsys.readouterr().err.strip().splitlines()
        if status == 2:
            assert len(err) == 1 and "Traceback" not in err[0], (option, value, err)
            continue
        assert status == 0 and out.stat().st_size > 0, (option, value, err)
        rendered += 1
    assert rendered >= 1, option


def test_building_the_parser_imports_no_numerical_library():
    """`fg-tea --help` and every usage error stay quick: no numpy while the parser is built."""
    import subprocess
    import sys

    code = ("import sys\nfrom fg_tea.cli.main import build_parser\nbuild_parser()\n"
            "print(sorted(m for m in ('numpy', 'scipy', 'gtsam', 'pybullet') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0 and out.stdout.strip() == "[]", out.stdout + out.stderr


def test_the_house_rooms_flag_takes_its_range_from_the_generator():
    from fg_tea.world.housegen import MAX_ROOMS, MIN_ROOMS

    assert dict(BOUNDED)[("house", "--rooms")].bounds == (MIN_ROOMS, MAX_ROOMS)
    house = next(a for a in build_parser()._subparsers._group_actions[0].choices["house"]._actions  # noqa: SLF001
                 if "--rooms" in a.option_strings)
    assert f"{MIN_ROOMS} to {MAX_ROOMS}" in house.help
