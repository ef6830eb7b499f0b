"""A building's layout seen one floor at a time, for the writers that draw each floor."""

from __future__ import annotations

from floorplan.models import Layout


def floor_layout(layout: Layout, floor_id: str) -> Layout:
    """Floor `floor_id` of a building's layout as a single-floor layout."""
    floor = next(f for f in layout.floors or [] if f.id == floor_id)
    return Layout(name=floor.name, rooms=floor.rooms, doors=floor.doors,
                  windows=floor.windows, report=floor.report)
