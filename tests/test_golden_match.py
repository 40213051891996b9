"""The golden comparison (tests/golden_match.py) itself: it forgives last-bit noise and nothing else.

Checked on a real golden log (tests/golden/) and on small hand-made values: a float moved by a
relative 1e-14 passes, one moved by 1e-8 fails; a moved decision, a changed count, a key added,
an event more, an integer that became a float all fail, and the message names the event (index
and kind), the JSON path and both values. The same for CSV rows, matched by key.
"""

from __future__ import annotations

import copy
import csv
import io
from pathlib import Path

from golden_match import (cell_differences, csv_differences, differences, event_differences, floats_match,
                          read_logs, read_xz_text, report)

GOLDEN = Path(__file__).resolve().parent / "golden"
NAME = "default_apartment-joint-0"


def _log() -> list[dict]:
    return read_logs(GOLDEN / "episode_logs.jsonl.xz")[NAME]


def _scale_floats(value, factor):
    """Every float in `value` times `factor` (last-bit noise when factor is 1 + 1e-14)."""
    if isinstance(value, float):
        return value * factor
    if isinstance(value, dict):
        return {k: _scale_floats(v, factor) for k, v in value.items()}
    if isinstance(value, list):
        return [_scale_floats(v, factor) for v in value]
    return value


def test_last_bit_noise_on_every_float_of_a_golden_log_passes():
    events = _log()
    noisy = _scale_floats(events, 1 + 1e-14)
    assert noisy != events  # the noise did move floats
    assert event_differences(events, noisy) == []


def test_every_float_moved_beyond_nine_digits_fails():
    events = _log()
    found = event_differences(events, _scale_floats(events, 1 + 1e-8))
    assert found and all("expected" in f and "got" in f for f in found)


def test_a_moved_decision_fails_naming_the_event_path_and_values():
    events = _log()
    moved = copy.deepcopy(events)
    i = next(n for n, e in enumerate(moved) if e["event"] == "decision")
    before = moved[i]["viewpoint"]
    other = next(c["viewpoint"] for c in moved[i]["candidates"] if c["viewpoint"] != before)
    moved[i]["viewpoint"] = other
    found = event_differences(events, moved)
    assert found == [f"event {i} (decision): $.viewpoint: expected {before!r}, got {other!r}"]
    message = report(f"tests/golden/episode_logs.jsonl.xz [{NAME}]", found)
    assert message.startswith(f"tests/golden/episode_logs.jsonl.xz [{NAME}]: 1 difference(s)")
    assert f"event {i} (decision): $.viewpoint" in message


def test_a_number_moved_in_a_candidate_fails_and_noise_there_passes():
    events = _log()
    i = next(n for n, e in enumerate(events) if e["event"] == "decision")
    key = next(k for k, v in events[i]["candidates"][1].items() if isinstance(v, float) and v != 0.0)
    for factor, fails in ((1 + 1e-14, False), (1 - 1e-14, False), (1 + 2e-9, True), (1.001, True)):
        moved = copy.deepcopy(events)
        moved[i]["candidates"][1][key] *= factor
        found = event_differences(events, moved)
        assert bool(found) == fails, (factor, found)
        if fails:
            assert found[0].startswith(f"event {i} (decision): $.candidates[1].{key}: expected ")


def test_structure_and_exact_values_are_strict():
    assert list(differences({"a": 1}, {"a": 2})) == ["$.a: expected 1, got 2"]
    assert list(differences({"a": 1}, {"a": 1.0})) == ["$.a: expected int 1, got float 1.0"]
    assert list(differences({"a": True}, {"a": 1})) == ["$.a: expected bool true, got int 1"]
    assert list(differences({"a": None}, {"a": 0.0})) == ["$.a: expected NoneType null, got float 0.0"]
    assert list(differences({"a": 1}, {"a": 1, "b": 2})) == ["$: keys missing [], keys added ['b']"]
    assert list(differences([1, 2], [1, 2, 3])) == ["$: expected 2 items, got 3"]
    assert list(differences({"s": "kitchen"}, {"s": "kitchen "})) == ["$.s: expected 'kitchen', got 'kitchen '"]
    events = _log()
    shorter = event_differences(events, events[:-1])
    assert shorter == [f"the log has {len(events) - 1} events, the golden one {len(events)}"]


def test_floats_near_zero_and_special_values():
    assert floats_match(0.0, 1e-17) and floats_match(-0.0, 0.0)
    assert not floats_match(0.0, 1e-9)
    assert floats_match(float("nan"), float("nan")) and not floats_match(float("nan"), 0.0)
    assert floats_match(float("inf"), float("inf")) and not floats_match(float("inf"), float("-inf"))
    x = 0.08368670986249375  # a CSV's quality_kl_mean, the number whose last bits broke the digest
    assert floats_match(x, x * (1 + 1e-14)) and not floats_match(x, x * (1 + 1e-8))


def _csv(rows: list[dict]) -> str:
    out = io.StringIO()
    writer = csv.DictWriter(out, fieldnames=list(rows[0]))
    writer.writeheader()
    writer.writerows(rows)
    return out.getvalue()


def test_csv_rows_compare_by_key_and_cells_to_nine_digits():
    golden = read_xz_text(GOLDEN / "compare_quick_episodes.csv.xz")
    rows = list(csv.DictReader(io.StringIO(golden)))
    assert csv_differences(golden, golden, key="key") == []
    assert csv_differences(golden, _csv(rows[::-1]), key="key") == ["the same rows in another order"]
    noisy = [dict(r, quality_kl_mean=repr(float(r["quality_kl_mean"]) * (1 + 1e-14))) for r in rows]
    assert noisy != rows and csv_differences(golden, _csv(noisy), key="key") == []
    moved = [dict(r) for r in rows]
    moved[3]["planner"] = "nearest" if moved[3]["planner"] != "nearest" else "efe"
    moved[5]["quality_kl_mean"] = repr(float(moved[5]["quality_kl_mean"]) * (1 + 1e-6))
    found = csv_differences(golden, _csv(moved), key="key")
    assert [f.split(":")[0] for f in found] == [f"row {rows[3]['key']!r}, column planner",
                                               f"row {rows[5]['key']!r}, column quality_kl_mean"]
    assert csv_differences(golden, _csv([{k: v for k, v in r.items() if k != "spl"} for r in rows]), key="key")[0] \
        == "columns: missing ['spl'], added []"
    assert "rows missing" in csv_differences(golden, _csv(rows[1:]), key="key")[0]


def test_csv_cells_integers_and_text_are_exact():
    assert list(cell_differences("7", "7")) == []
    assert list(cell_differences("7", "7.0")) == ["expected '7', got '7.0'"]
    assert list(cell_differences("True", "False")) == ["expected 'True', got 'False'"]
    assert list(cell_differences("4.50451;3.468281", "4.50451;3.468281000000001")) == []
    assert list(cell_differences("4.50451;3.468281", "4.50451;3.47")) == ["[1] expected 3.468281, got 3.47"]
    assert list(cell_differences("4.50451;3.468281", "4.50451")) != []
