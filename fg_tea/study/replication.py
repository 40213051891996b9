"""Replication built into the method (docs/design.md §11.1): a discovery set of worlds and a
confirmation set declared before anything runs, judged cell by cell.

A *cell* is one comparison of two configurations (by default the joint against the factorised
belief) within one stratum (world distribution, task, planner). For each seed set it reports
the paired difference of a metric, world by world, with

- the raw 95 % Student-t interval, and a Bonferroni interval adjusted for the number of cells;
- the t-test p-value and its Holm adjustment over the cells (family-wise error at most 5 %);
- the share of worlds in which the two configurations' searches differed at all (same search
  travel and inspections = the same searches), and the effect conditional on differing;
- from the discovery set, the paired worlds a two-sided test at 95 % needs to resolve a
  difference of 3 % of the baseline's search travel with 80 % power (:func:`pairs_needed`).

A cell's claim is **established** only when the confirmation set's Holm-adjusted p is below 0.05
and its mean difference has the sign of the discovery set's; **no difference** when neither set
has a single world in which the choices differed; **no pairs** when a set has none (a planner
refused one of the beliefs: its rows say ``refused:``); otherwise **not resolved**, with both
intervals given. The seed sets are written to ``seed_sets.json`` before the first episode
(:func:`declare_seed_sets`), and a later run with other sets in the same folder is refused.
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np

from fg_tea.common.errors import InputError
from fg_tea.common.files import atomic_write_text
from fg_tea.common.stats import (Interval, bonferroni_interval, holm, pairs_needed, t_interval,
                                 t_test_p)
from fg_tea.study.analysis import PAIR_ON, excluded, markdown_table

SEED_SETS_FILE = "seed_sets.json"
#: The difference a cell should be able to resolve: this share of the baseline's mean metric.
RESOLVE_SHARE = 0.03
#: The power at which :func:`pairs_needed` sizes a cell.
POWER = 0.8
#: Columns whose equality means "the same searches" (two runs that chose the same looks).
SAME_CHOICES = ("search_distance", "inspections")
ESTABLISHED, NOT_RESOLVED, NO_DIFFERENCE = "established", "not resolved", "no difference"
#: A cell with no pair in a set: a planner refused the belief (a ``refused:`` row) or it did not run.
NO_PAIRS = "no pairs"


@dataclass(frozen=True)
class SeedSet:
    """World seeds ``first .. first + count - 1`` under a name (``discovery``, ``confirmation``)."""

    name: str
    first: int
    count: int

    def __contains__(self, seed: object) -> bool:
        return isinstance(seed, int) and self.first <= seed < self.first + self.count

    @property
    def label(self) -> str:
        return f"{self.name} (world seeds {self.first}-{self.first + self.count - 1})"


def check_seed_sets(sets: Sequence[SeedSet]) -> None:
    """Refuse empty, negative or overlapping seed sets (one line each).

    Raises:
        InputError: naming the set at fault.
    """
    for s in sets:
        if s.count < 1 or s.first < 0:
            raise InputError("<command line>", s.name, f"expected at least one world from a "
                             f"non-negative seed, got first={s.first}, count={s.count}")
    for i, a in enumerate(sets):
        for b in sets[i + 1:]:
            if a.first < b.first + b.count and b.first < a.first + a.count:
                raise InputError("<command line>", b.name, f"world seeds {b.first}-"
                                 f"{b.first + b.count - 1} overlap the {a.name} set's "
                                 f"{a.first}-{a.first + a.count - 1}: the sets must be disjoint")


def declare_seed_sets(out: Path, sets: Sequence[SeedSet]) -> Path:
    """Write the seed sets to ``out/seed_sets.json`` before any episode runs.

    A folder that already declares sets keeps them: the same sets pass, other sets are refused,
    so a confirmation set cannot be chosen after its results are seen.

    Raises:
        InputError: other sets than the folder's declaration, or overlapping sets.
    """
    check_seed_sets(sets)
    path = Path(out) / SEED_SETS_FILE
    wanted = [asdict(s) for s in sets]
    if path.exists():
        try:
            declared = json.loads(path.read_text())["sets"]
        except (OSError, ValueError, KeyError, TypeError):
            raise InputError(path, "sets", "not a seed-set declaration written by fg_tea") from None
        if declared != wanted:
            raise InputError(path, "sets", f"this folder declared {declared}; a run with other "
                             "seed sets goes to another --out")
        return path
    path.parent.mkdir(parents=True, exist_ok=True)
    return atomic_write_text(path, json.dumps({"sets": wanted}, indent=2) + "\n")


def read_seed_sets(out: Path) -> list[SeedSet]:
    """The seed sets a folder declared (empty when it declared none)."""
    path = Path(out) / SEED_SETS_FILE
    if not path.exists():
        return []
    return [SeedSet(**s) for s in json.loads(path.read_text())["sets"]]


def _pairs(rows: Sequence[Mapping[str, Any]], vary: str, a: Any, b: Any
           ) -> list[tuple[Mapping[str, Any], Mapping[str, Any]]]:
    table: dict[Any, dict[tuple, Mapping[str, Any]]] = {a: {}, b: {}}
    for r in rows:
        if r.get(vary) in table and not excluded(r):
            table[r.get(vary)][tuple(r.get(c) for c in PAIR_ON)] = r
    return [(table[a][k], table[b][k]) for k in table[a] if k in table[b]]


def _num(v: Any) -> float:
    try:
        return float(v)
    except (TypeError, ValueError):
        return math.nan


def replication_cells(rows: Sequence[Mapping[str, Any]], sets: Sequence[SeedSet], *,
                      vary: str = "model", baseline: Any = "factorised", other: Any = "joint",
                      by: Sequence[str] = ("world", "task", "planner"),
                      metric: str = "search_distance", confidence: float = 0.95
                      ) -> list[dict[str, Any]]:
    """One entry per cell: the `by` columns and, per seed set, its statistics (module docstring).

    The first set is the discovery set (it sizes the cells); the last is the confirmation set
    (it decides the verdict). Holm's adjustment and the Bonferroni intervals run over the cells.
    """
    cells: dict[tuple, dict[str, list]] = {}
    for r in rows:
        cells.setdefault(tuple(r.get(c) for c in by), {}).setdefault("rows", []).append(r)
    out = []
    for key, group in cells.items():
        entry: dict[str, Any] = dict(zip(by, key))
        for s in sets:
            pairs = _pairs([r for r in group["rows"] if int(r.get("world_seed", -1)) in s],
                           vary, baseline, other)
            diffs = [_num(b.get(metric)) - _num(a.get(metric)) for a, b in pairs]
            differ = [d for (a, b), d in zip(pairs, diffs)
                      if any(_num(a.get(c)) != _num(b.get(c)) for c in SAME_CHOICES)]
            base = t_interval(_num(a.get(metric)) for a, _ in pairs)
            entry[s.name] = {"pairs": len(pairs), "difference": t_interval(diffs, confidence),
                             "diffs": diffs, "p": t_test_p(diffs), "baseline": base.mean,
                             "share_differ": len(differ) / len(pairs) if pairs else math.nan,
                             "if_differ": t_interval(differ, confidence)}
        first = entry[sets[0].name]
        sd = float(_sd(first["diffs"]))
        entry["resolve"] = RESOLVE_SHARE * first["baseline"] if first["pairs"] else math.nan
        entry["pairs_needed"] = pairs_needed(sd, entry["resolve"], confidence, POWER)
        out.append(entry)
    return adjust(out, sets, confidence)


def adjust(cells: list[dict[str, Any]], sets: Sequence[SeedSet], confidence: float = 0.95
           ) -> list[dict[str, Any]]:
    """Holm's p and Bonferroni intervals over all `cells` (one family of comparisons), and each
    cell's verdict; returns `cells`. Call it again on the union of several comparisons' cells
    to adjust over all of them."""
    for s in sets:
        adjusted = holm([c[s.name]["p"] for c in cells])
        for c, p in zip(cells, adjusted):
            c[s.name]["p_holm"] = p
            c[s.name]["adjusted"] = bonferroni_interval(c[s.name]["diffs"], len(cells), confidence)
    for c in cells:
        c["verdict"] = verdict(c[sets[0].name], c[sets[-1].name], 1 - confidence)
    return cells


def _sd(values: Sequence[float]) -> float:
    """The sample standard deviation (ddof 1) of the finite values; NaN below two."""
    x = np.asarray([v for v in values if math.isfinite(v)], dtype=float)
    return float(x.std(ddof=1)) if len(x) >= 2 else math.nan


def verdict(discovery: Mapping[str, Any], confirmation: Mapping[str, Any], alpha: float = 0.05) -> str:
    """``established``, ``no difference``, ``not resolved`` or ``no pairs`` (module docstring)."""
    if not discovery["pairs"] or not confirmation["pairs"]:
        return NO_PAIRS
    if discovery["share_differ"] == 0 and confirmation["share_differ"] == 0:
        return NO_DIFFERENCE
    d, c = discovery["difference"].mean, confirmation["difference"].mean
    if (confirmation["p_holm"] < alpha and math.isfinite(d) and d != 0
            and math.copysign(1, d) == math.copysign(1, c)):
        return ESTABLISHED
    return NOT_RESOLVED


def _percent(entry: Mapping[str, Any]) -> Interval:
    """A seed set's difference and interval in per cent of the baseline's mean on the same worlds."""
    d, base = entry["difference"], entry.get("baseline")
    if not base or not entry["pairs"]:
        return Interval(math.nan, math.nan, math.nan, 0)
    return Interval(100.0 * d.mean / base, 100.0 * d.low / base, 100.0 * d.high / base, d.n)


def replication_markdown(cells: Sequence[Mapping[str, Any]], sets: Sequence[SeedSet],
                         by: Sequence[str] = ("world", "task", "planner"),
                         metric: str = "search_distance", compared: str = "beliefs") -> str:
    """The replication table: per cell and seed set the raw and adjusted intervals, Holm's p,
    the share of worlds whose choices differed and the effect there; the pairs needed; the verdict."""
    header = [*by]
    for s in sets:
        header += [f"{s.name}: pairs", f"{s.name}: difference [95 % CI]",
                   f"{s.name}: % of the baseline [95 % CI]",
                   f"{s.name}: adjusted [CI over {len(cells)} cells]", f"{s.name}: Holm p",
                   f"{s.name}: worlds that differ", f"{s.name}: difference where they differ"]
    header += [f"pairs to resolve {RESOLVE_SHARE:.0%}", "verdict"]
    body = []
    for c in cells:
        line = [str(c[b]) for b in by]
        for s in sets:
            e = c[s.name]
            none = not e["pairs"]
            line += [str(e["pairs"]), e["difference"].fmt(), _percent(e).fmt(1), e["adjusted"].fmt(),
                     "–" if none else f"{e['p_holm']:.3g}",
                     "–" if none else f"{e['share_differ']:.0%}", e["if_differ"].fmt()]
        need = c["pairs_needed"]
        line += [f"{need:,} ({c['resolve']:.2f} m)" if need else "—", f"**{c['verdict']}**"
                 if c["verdict"] == ESTABLISHED else c["verdict"]]
        body.append(line)
    sets_text = "; ".join(s.label for s in sets)
    return "\n".join([
        f"Seed sets, declared before the runs: {sets_text}. Each cell is the paired difference of "
        f"`{metric}` world by world (also in per cent of the baseline's mean on the same worlds). "
        "A claim is established only where the confirmation set's "
        "Holm-adjusted p is below 0.05 with the discovery set's sign; the adjusted intervals are "
        f"Bonferroni intervals over the {len(cells)} cells. \"Worlds that differ\": the share of "
        f"paired worlds in which the two {compared}' searches differed at all; the next column is "
        f"the effect in those worlds. \"Pairs to resolve\": paired worlds a 95 % test needs to "
        f"detect {RESOLVE_SHARE:.0%} of the baseline's search travel with {POWER:.0%} power, "
        "from the discovery set's spread. \"No pairs\": a set without a single pair (a planner "
        "refused a belief, e.g. the lookahead beyond its joint-size limit).", "",
        markdown_table(header, body), ""])


def pairs_to_resolve_lines(rows: Sequence[Mapping[str, Any]], vary: str, baseline: Any,
                           by: Sequence[str] = ("planner",), metric: str = "search_distance"
                           ) -> list[str]:
    """One line per cell of a single comparison: how many paired worlds would resolve
    :data:`RESOLVE_SHARE` of the baseline's `metric` at 80 % power, beside the pairs it has."""
    lines = []
    others = [v for v in dict.fromkeys(r.get(vary) for r in rows) if v != baseline]
    groups: dict[tuple, list] = {}
    for r in rows:
        groups.setdefault(tuple(r.get(c) for c in by), []).append(r)
    for key, group in groups.items():
        for other in others:
            pairs = _pairs(group, vary, baseline, other)
            if len(pairs) < 2:
                continue
            diffs = [_num(b.get(metric)) - _num(a.get(metric)) for a, b in pairs]
            base = t_interval(_num(a.get(metric)) for a, _ in pairs).mean
            need = pairs_needed(_sd(diffs), RESOLVE_SHARE * base)
            where = ", ".join(f"{b}={k}" for b, k in zip(by, key))
            head = f"{other} - {baseline} ({where}): {t_interval(diffs).fmt()} over {len(pairs)} pairs"
            if need is None:
                lines.append(f"{head}; no spread, nothing to resolve")
            else:
                lines.append(f"{head}; ~{need:,} pairs would resolve {RESOLVE_SHARE:.0%} of "
                             f"{metric} ({RESOLVE_SHARE * base:.2f}) at {POWER:.0%} power")
    return lines


__all__ = ["adjust", "SEED_SETS_FILE", "RESOLVE_SHARE", "POWER", "ESTABLISHED", "NOT_RESOLVED", "NO_DIFFERENCE",
           "NO_PAIRS",
           "SeedSet", "check_seed_sets", "declare_seed_sets", "read_seed_sets", "replication_cells",
           "verdict", "replication_markdown", "pairs_to_resolve_lines"]
