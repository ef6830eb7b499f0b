"""The job backend the settings ask for."""

from __future__ import annotations

from floorplan.service.jobs.backend import JobBackend
from floorplan.service.jobs.embedded import EmbeddedBackend
from floorplan.service.settings import Settings


def make_backend(settings: Settings) -> JobBackend:
    """The backend FLOORPLAN_BACKEND names."""
    if settings.backend == "celery":
        from floorplan.service.jobs.celery.backend import (
            CeleryBackend,  # needs the `distributed` extra
        )

        return CeleryBackend(settings)
    return EmbeddedBackend(settings)
