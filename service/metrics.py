"""Prometheus metrics, one registry per app (so tests can run several apps in one process)."""

from __future__ import annotations

from dataclasses import dataclass

from prometheus_client import CollectorRegistry, Counter, Gauge, Histogram


@dataclass
class Metrics:
    registry: CollectorRegistry
    requests: Counter
    plan_seconds: Histogram
    plans_in_flight: Gauge
    rejected: Counter
    batch_size: Histogram

    @staticmethod
    def create() -> Metrics:
        registry = CollectorRegistry()
        return Metrics(
            registry=registry,
            requests=Counter(
                "gfc_http_requests",
                "HTTP requests by route and status",
                ["route", "status"],
                registry=registry,
            ),
            plan_seconds=Histogram(
                "gfc_plan_seconds",
                "wall time of POST /plan sampling",
                buckets=(0.05, 0.1, 0.2, 0.5, 1, 2, 5, 10, 30),
                registry=registry,
            ),
            plans_in_flight=Gauge("gfc_plans_in_flight", "plans running or queued", registry=registry),
            rejected=Counter("gfc_plans_rejected", "plans refused with 503 (overload)", registry=registry),
            batch_size=Histogram(
                "gfc_plan_batch_size",
                "plans sampled together in one run (micro-batching)",
                buckets=(1, 2, 3, 4, 6, 8, 16, 32, 64),
                registry=registry,
            ),
        )
