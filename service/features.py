"""Importing this module registers every feature's event handlers with ingest."""

from types import ModuleType

from service.clearance import handlers as clearance_handlers
from service.clearance import tail as clearance_tail
from service.fleet import handlers as fleet_handlers
from service.trains import handlers as train_handlers

LOADED: tuple[ModuleType, ...] = (
    clearance_handlers,
    clearance_tail,
    fleet_handlers,
    train_handlers,
)
