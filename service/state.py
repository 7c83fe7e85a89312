"""Everything a request handler needs, built once per app."""

from __future__ import annotations

from dataclasses import dataclass

from gfc.planner.library import SkillLibrary
from service.admin import SkillAdmin
from service.batcher import PlanBatcher
from service.catalog import SkillCatalog
from service.jobs import JobStore
from service.limits import Admission
from service.metrics import Metrics
from service.settings import Settings


@dataclass
class ServiceState:
    settings: Settings
    library: SkillLibrary
    catalog: SkillCatalog
    admission: Admission
    metrics: Metrics
    jobs: JobStore
    batcher: PlanBatcher
    admin: SkillAdmin | None = None  # store-backed services only
