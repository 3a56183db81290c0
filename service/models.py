"""Every table, imported in one place so that Alembic and replay see the whole schema."""

from core.database import Base
from core.models import Car, CredentialChange, Device, Section, Station, User
from ingest.models import RawEvent, Snapshot
from service.clearance.models import AuditRecord, AxleReading, CarPassage, Run, WheelMarking
from service.fleet.models import Forecast, MaintenanceOverride, Measurement, Parameter
from service.review.models import ReviewSession
from service.trains.models import TrackMarker, TrainPosition

metadata = Base.metadata

__all__ = [
    "AuditRecord",
    "AxleReading",
    "Car",
    "CarPassage",
    "CredentialChange",
    "Device",
    "Forecast",
    "MaintenanceOverride",
    "Measurement",
    "Parameter",
    "RawEvent",
    "ReviewSession",
    "Run",
    "Section",
    "Snapshot",
    "Station",
    "TrackMarker",
    "TrainPosition",
    "User",
    "WheelMarking",
    "metadata",
]
