"""What both clients are configured with: where the service is, timeouts, retry policy."""

from __future__ import annotations

import os
from collections.abc import Mapping
from dataclasses import dataclass

import httpx

from gfc_client._flow import Send
from gfc_client._retry import RetryPolicy
from gfc_client._version import __version__

DEFAULT_URL = "http://127.0.0.1:8000"
URL_ENV = "GFC_URL"
DEFAULT_TIMEOUT = 60.0  # seconds per request; planning with many samples can take a while
DEFAULT_MAX_RETRIES = 2

Timeout = float | httpx.Timeout | None


@dataclass(frozen=True)
class ClientSettings:
    base_url: str
    timeout: Timeout
    retry: RetryPolicy
    headers: Mapping[str, str]

    @classmethod
    def create(
        cls,
        base_url: str | None,
        timeout: Timeout,
        max_retries: int,
        retry: RetryPolicy | None,
        headers: Mapping[str, str] | None,
    ) -> ClientSettings:
        url = base_url or os.environ.get(URL_ENV) or DEFAULT_URL
        if not url.startswith(("http://", "https://")):
            raise ValueError(f"base_url must start with http:// or https://, got {url!r}")
        return cls(
            base_url=url.rstrip("/"),
            timeout=timeout,
            retry=retry or RetryPolicy(max_retries=max_retries),
            headers={"User-Agent": f"gfc-client/{__version__}", **(headers or {})},
        )


def build_request(http: httpx.Client | httpx.AsyncClient, send: Send, default: Timeout) -> httpx.Request:
    timeout = default if send.timeout is None else send.timeout
    return http.build_request(
        send.method, send.path, json=send.json, headers=dict(send.headers), timeout=timeout
    )
