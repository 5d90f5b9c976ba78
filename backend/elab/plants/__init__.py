"""The plants of the lab: pure data, one module each, and a registry."""

from __future__ import annotations

from elab.errors import NotFound
from elab.plants import belt_conveyor, double_pendulum, flexible_link
from elab.plants.base import (
    Channel,
    LessonStep,
    Plant,
    Sensors,
    SignalDefaults,
    VelocityFilter,
)

PLANTS: dict[str, Plant] = {
    p.id: p for p in (flexible_link.PLANT, double_pendulum.PLANT, belt_conveyor.PLANT)
}


def get_plant(plant_id: str) -> Plant:
    """The plant with this id; :class:`~elab.errors.NotFound` names the known ids."""
    try:
        return PLANTS[plant_id]
    except KeyError:
        raise NotFound("plant", plant_id, sorted(PLANTS)) from None


__all__ = [
    "PLANTS",
    "Channel",
    "LessonStep",
    "Plant",
    "Sensors",
    "SignalDefaults",
    "VelocityFilter",
    "get_plant",
]
