"""Python SDK for the gfc planning service.

``Client`` (synchronous) and ``AsyncClient`` (asyncio) share one implementation of requests,
retries, parsing and errors; ``PlanBuilder`` writes plan JSON; ``models`` holds the typed
responses. See docs/sdk.md.
"""

from gfc_client._client import AsyncClient, Client
from gfc_client._errors import (
    APIConnectionError,
    APIError,
    APIStatusError,
    APITimeoutError,
    AuthenticationError,
    BadRequestError,
    ConflictError,
    GFCError,
    InternalServerError,
    JobWaitTimeout,
    NotFoundError,
    RateLimitError,
    RequestTooLargeError,
    UnprocessableEntityError,
)
from gfc_client._retry import RetryPolicy
from gfc_client._version import __version__
from gfc_client.builder import PlanBuilder
from gfc_client.models import (
    Candidate,
    CandidateOutcome,
    Health,
    Issue,
    Job,
    JobAccepted,
    JobStatus,
    NodeState,
    PlanResponse,
    Readiness,
    Residual,
    Skill,
    SkillVersion,
    StepOutcome,
    StepParameters,
    VerifyResult,
)

__all__ = [
    "APIConnectionError",
    "APIError",
    "APIStatusError",
    "APITimeoutError",
    "AsyncClient",
    "AuthenticationError",
    "BadRequestError",
    "Candidate",
    "CandidateOutcome",
    "Client",
    "ConflictError",
    "GFCError",
    "Health",
    "InternalServerError",
    "Issue",
    "Job",
    "JobAccepted",
    "JobStatus",
    "JobWaitTimeout",
    "NodeState",
    "NotFoundError",
    "PlanBuilder",
    "PlanResponse",
    "RateLimitError",
    "Readiness",
    "RequestTooLargeError",
    "Residual",
    "RetryPolicy",
    "Skill",
    "SkillVersion",
    "StepOutcome",
    "StepParameters",
    "UnprocessableEntityError",
    "VerifyResult",
    "__version__",
]
