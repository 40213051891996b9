"""Small wall-less test houses built in code (shared by the planning tests)."""

from __future__ import annotations

from fg_tea.world.scenario import parse_scenario


def make_scenario(sites, objects, start=(0.0, 0.0)):
    """A wall-less test house. sites: (name, room, (x, y) vantage, affordances[, capacity])."""
    site_docs = []
    for s in sites:
        name, room, (x, y), aff = s[:4]
        doc = {"name": name, "room": room, "position": [x, y, 0.8],
               "vantage_position": [x, y, 0.0], "affordances": aff}
        if len(s) > 4 and s[4] is not None:
            doc["capacity"] = s[4]
        site_docs.append(doc)
    return parse_scenario({
        "schema_version": 2, "name": "test_house",
        "start_pose": {"position": list(start)},
        "house": {"floor": {"min": [-10, -10], "max": [20, 20]}, "walls": [], "furniture": []},
        "sites": site_docs,
        "objects": [{"name": o, "category": c, "true_site": t, "semantic_id": i + 1}
                    for i, (o, c, t) in enumerate(objects)],
    })


def set_at(path, value):
    """An edit of a JSON-like document: set the item at `path` (keys and indices) to `value`."""
    def edit(data):
        node = data
        for key in path[:-1]:
            node = node[key]
        node[path[-1]] = value
    return edit
