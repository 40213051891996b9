"""``fg-tea house``: generate a house scenario from a seed (fg_tea.world.housegen).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from fg_tea.cli.common import check_out_file, command, integer, out_path
from fg_tea.common.errors import InputError


# ------------------------------------------------------------------------------ house generator
@command("house")
def cmd_house(args: argparse.Namespace) -> int:
    """Generate a house scenario (rooms, furniture sites, room vantages, priors, objects)."""
    from fg_tea.world.housegen import check_arguments, write_house

    objects = [o.strip() for o in args.objects.split(",") if o.strip()]
    try:
        objects = list(check_arguments(args.rooms, args.seed, objects))
    except ValueError as exc:
        field, _, fault = str(exc).partition(": ")
        raise InputError("<command line>", f"--{field}", fault) from None
    out = check_out_file(Path(args.out))
    if out.is_dir() or not out.name:
        raise InputError(out, "$", "is a folder; expected a scenario file name")
    try:
        if args.sites_per_room is None:
            doc = write_house(out, args.rooms, args.seed, objects, args.name)
        else:
            from fg_tea.common.files import atomic_write_text
            from fg_tea.world.housegen import generate_house, house_json
            from fg_tea.world.scenario import keep_sites

            try:
                doc = keep_sites(generate_house(args.rooms, args.seed, objects, args.name), args.sites_per_room)
            except ValueError as exc:
                raise InputError("<command line>", "--sites-per-room", str(exc).split(": ", 1)[-1]) from None
            atomic_write_text(out, house_json(doc))
    except OSError as exc:
        raise InputError(out, "$", f"cannot write the scenario: {exc.strerror or exc}") from None
    print(f"house: {out} ({args.rooms} rooms, {len(doc['sites'])} sites, "
          f"{len(doc['room_vantages'])} room vantages, objects {', '.join(objects)})")
    return 0


class _Rooms:
    """The ``--rooms`` type: an integer in the generator's range, read from
    :mod:`fg_tea.world.housegen` only when a value is parsed (building the parser imports no numpy)."""

    __name__ = "rooms"

    @property
    def bounds(self) -> tuple[int, int]:
        from fg_tea.world.housegen import MAX_ROOMS, MIN_ROOMS

        return MIN_ROOMS, MAX_ROOMS

    def __call__(self, text: str) -> int:
        return integer(*self.bounds)(text)


def add_parser(sub) -> None:
    p = sub.add_parser("house", help="generate a house scenario JSON from a seed",
                       description="Write a schema-2 scenario of a generated house: N rectangular "
                       "rooms joined by doorways (the first a kitchen), furniture along the walls "
                       "whose tops are semantic sites, room vantages, affordance priors by room and "
                       "furniture type, and objects placed from those priors. Same arguments, same "
                       "bytes.")
    p.add_argument("--rooms", type=_Rooms(), required=True, help="number of rooms, 3 to 10")
    p.add_argument("--seed", type=integer(0), default=0, help="non-negative seed (default: %(default)s)")
    p.add_argument("--out", required=True, type=out_path, help="output scenario JSON")
    p.add_argument("--objects", default="mug,kettle,teabag",
                   help="comma-separated objects among mug, kettle, teabag, milk, sugar "
                   "(default: %(default)s)")
    p.add_argument("--name", help="scenario name (default: generated_<rooms>r_seed<seed>)")
    p.add_argument("--sites-per-room", type=integer(1), default=None, metavar="N",
                   help="keep only the first N sites of each room (the preparation site always): a "
                   "small house whose furniture stays, for the search limit (docs/design.md §6.9); "
                   "default: every site")
