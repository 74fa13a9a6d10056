"""Payload mass from an OpenAI-compatible vision chat model (the paper's ``Phi_VLM(I, D)``).

Any server speaking the chat-completions API works (OpenAI's GPT-4o as in the paper, a local
Ollama or vLLM), through the official ``openai`` client. Retries, timeouts and the answer cache
follow :class:`VLMConfig`; the prompt and the answer's validation live in
:mod:`forte.force.vlm_answer`, the cache in :mod:`forte.force.vlm_cache`.
"""

from __future__ import annotations

import hashlib
import logging
import math
import os
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any
from urllib.parse import urlparse

from forte.exceptions import EstimationError, InvalidInputError
from forte.force.images import ImageInput, data_url, image_bytes
from forte.force.mass import MassEstimate
from forte.force.vlm_answer import DEFAULT_DESCRIPTION, PROMPT_VERSION, RESPONSE_FORMAT, SYSTEM_PROMPT, parse_answer
from forte.force.vlm_cache import cache_key, read_entry, server_id, write_entry

log = logging.getLogger(__name__)

_PLACEHOLDER_KEY = "unused"  # local servers (Ollama, vLLM) accept any key but the client needs one


@dataclass(frozen=True)
class VLMConfig:
    """How to reach an OpenAI-compatible chat-completions server.

    Attributes:
        base_url: server root including ``/v1`` (OpenAI, ``http://localhost:11434/v1`` for Ollama,
            ``http://host:8000/v1`` for vLLM).
        model: model name (the paper uses ``gpt-4o``).
        api_key_env: name of the environment variable holding the key; the key itself is never
            stored here, logged or cached. When the variable is unset a placeholder is sent, which
            local servers accept; ``api.openai.com`` then fails with a clear error.
        timeout_s: per-request timeout.
        max_retries: retries after the first attempt on HTTP 429, 5xx, timeouts and connection
            errors; other failures are not retried.
        backoff_base_s, backoff_max_s: the wait before retry ``k`` (0-based) is
            ``min(backoff_max_s, backoff_base_s 2^k)``, or the server's ``Retry-After`` if longer.
        max_tokens: cap on the answer length (``None`` to leave it to the server); a basket of
            objects takes a few hundred tokens.
        temperature: sampling temperature; 0 as in the authors' setup, for repeatable answers.
        cache: read and write the answer cache (when the estimator has a ``cache_dir``); False
            asks the server every time and leaves the cache as it is.
    """

    base_url: str = "https://api.openai.com/v1"
    model: str = "gpt-4o"
    api_key_env: str = "OPENAI_API_KEY"
    timeout_s: float = 60.0
    max_retries: int = 3
    backoff_base_s: float = 1.0
    backoff_max_s: float = 30.0
    max_tokens: int | None = 1024
    temperature: float = 0.0
    cache: bool = True

    def __post_init__(self) -> None:
        url = urlparse(self.base_url)
        if url.scheme not in ("http", "https") or not url.netloc:
            raise InvalidInputError(f"base_url: expected an http(s) URL, got {self.base_url!r}")
        if not self.model.strip():
            raise InvalidInputError("model: expected a model name, got an empty string")
        if not (math.isfinite(self.timeout_s) and self.timeout_s > 0):
            raise InvalidInputError(
                f"timeout_s: expected a positive number of seconds, got {self.timeout_s!r}"
            )
        if self.max_retries < 0:
            raise InvalidInputError(f"max_retries: expected >= 0, got {self.max_retries!r}")
        if self.backoff_base_s < 0 or self.backoff_max_s < 0:
            raise InvalidInputError("backoff_base_s, backoff_max_s: expected >= 0 seconds")
        if self.max_tokens is not None and self.max_tokens < 1:
            raise InvalidInputError(f"max_tokens: expected >= 1 or None, got {self.max_tokens!r}")
        if not (math.isfinite(self.temperature) and 0.0 <= self.temperature <= 2.0):
            raise InvalidInputError(f"temperature: expected a number in [0, 2], got {self.temperature!r}")

    def backoff(self, attempt: int) -> float:
        """Seconds to wait before retry ``attempt`` (0-based): ``min(max, base 2^attempt)``."""
        return min(self.backoff_max_s, self.backoff_base_s * 2.0**attempt)

    def request_options(self) -> dict[str, Any]:
        """The chat-completions options besides model and messages: all of them shape the answer."""
        options: dict[str, Any] = {"temperature": self.temperature, "response_format": RESPONSE_FORMAT}
        if self.max_tokens is not None:
            options["max_tokens"] = self.max_tokens
        return options


def _redact(text: str, secret: str | None) -> str:
    return text.replace(secret, "***") if secret else text


@dataclass
class VLMEstimator:
    """Payload mass from an OpenAI-compatible vision chat model (the paper's ``Phi_VLM(I, D)``).

    The image goes as a base64 data URL, the answer is constrained by
    :data:`~forte.force.vlm_answer.RESPONSE_FORMAT` (temperature 0 by default) and validated with
    :func:`~forte.force.vlm_answer.parse_answer`. Valid answers are cached under ``cache_dir``
    (unless ``config.cache`` is False), keyed by the server, the model, the prompt, the
    description, the image and the request options (see :func:`~forte.force.vlm_cache.cache_key`);
    invalid answers are neither retried nor cached. The client's own retries are disabled so that
    the retry policy is the one of :class:`VLMConfig`.
    """

    config: VLMConfig
    cache_dir: Path | None = None
    sleep: Callable[[float], None] = field(default=time.sleep, repr=False)
    name: str = "vlm"

    def __post_init__(self) -> None:
        import openai  # deferred: only a VLM run needs it

        self._openai = openai
        key = os.environ.get(self.config.api_key_env, "")
        host = urlparse(self.config.base_url).hostname or ""
        if not key and host.endswith("openai.com"):
            raise EstimationError(
                f"no API key: set the environment variable {self.config.api_key_env} "
                f"(or choose another one with --api-key-env)"
            )
        self._key = key or None
        self._client = openai.OpenAI(
            api_key=key or _PLACEHOLDER_KEY,
            base_url=self.config.base_url,
            timeout=self.config.timeout_s,
            max_retries=0,
        )

    @property
    def source(self) -> str:
        return f"{self.name}:{self.config.model}"

    @property
    def active_cache_dir(self) -> Path | None:
        """Where answers are read and written, or None when caching is off."""
        return Path(self.cache_dir) if self.cache_dir is not None and self.config.cache else None

    def estimate(self, description: str | None, image: ImageInput | None) -> MassEstimate:
        text = (description or "").strip() or DEFAULT_DESCRIPTION
        if image is None and not (description and description.strip()):
            raise InvalidInputError("give an image, a description or both")
        data, mime = image_bytes(image) if image is not None else (b"", "")
        request = self.request_identity(text, hashlib.sha256(data).hexdigest())
        key = cache_key(request)
        cache = self.active_cache_dir
        if cache is not None and (cached := read_entry(cache, key)) is not None:
            return cached
        content: list[dict[str, Any]] = [{"type": "text", "text": f"Task description: {text}"}]
        if data:
            content.append({"type": "image_url", "image_url": {"url": data_url(data, mime)}})
        messages = [{"role": "system", "content": SYSTEM_PROMPT}, {"role": "user", "content": content}]
        estimate = parse_answer(self._request(messages), self.source)
        if cache is not None:
            entry = {**request, "estimate": {k: v for k, v in estimate.to_dict().items() if k != "cached"}}
            write_entry(cache, key, entry)
        return estimate

    def request_identity(self, description: str, image_sha256: str) -> dict[str, Any]:
        """Everything that shapes the answer, the cache key's input; public facts only (no API key)."""
        return {
            "server": server_id(self.config.base_url),
            "model": self.config.model,
            "prompt_version": PROMPT_VERSION,
            "system_prompt": SYSTEM_PROMPT,
            "description": description,
            "image_sha256": image_sha256,
            "options": self.config.request_options(),
        }

    def _request(self, messages: list[dict[str, Any]]) -> str | None:
        oa = self._openai
        attempts = self.config.max_retries + 1
        last = ""
        for attempt in range(attempts):
            try:
                response = self._client.chat.completions.create(
                    model=self.config.model,
                    messages=messages,  # type: ignore[arg-type]
                    **self.config.request_options(),
                )
            except (
                oa.RateLimitError,
                oa.InternalServerError,
                oa.APITimeoutError,
                oa.APIConnectionError,
            ) as exc:
                last = self._describe(exc)
                if attempt + 1 >= attempts:
                    break
                wait = max(self.config.backoff(attempt), self._retry_after(exc))
                log.warning(
                    "VLM request %d/%d failed (%s); retrying in %.3g s", attempt + 1, attempts, last, wait
                )
                self.sleep(wait)
                continue
            except oa.APIStatusError as exc:  # 400, 401, 404 ...: retrying cannot help
                raise EstimationError(f"VLM server {self.config.base_url}: {self._describe(exc)}") from None
            except oa.OpenAIError as exc:
                raise EstimationError(f"VLM request failed: {self._describe(exc)}") from None
            return self._content(response)
        raise EstimationError(
            f"VLM server {self.config.base_url}: no valid response after {attempts} attempt(s), last: {last}"
        )

    def _content(self, response: Any) -> str | None:
        try:
            choice = response.choices[0]
        except (AttributeError, IndexError, TypeError):
            raise EstimationError("VLM answer: the response has no choices") from None
        if choice.finish_reason == "length":
            raise EstimationError("VLM answer: truncated (finish_reason 'length'); raise max_tokens")
        refusal = getattr(choice.message, "refusal", None)
        if refusal:
            raise EstimationError(f"VLM refused: {str(refusal)[:200]}")
        return choice.message.content

    def _describe(self, exc: Exception) -> str:
        oa = self._openai
        if isinstance(exc, oa.APITimeoutError):
            text = f"timed out after {self.config.timeout_s:g} s"
        elif isinstance(exc, oa.APIStatusError):
            text = f"HTTP {exc.status_code}: {str(exc.message)[:200]}"
        elif isinstance(exc, oa.APIConnectionError):
            text = f"connection failed ({exc.__cause__ or exc})"
        else:
            text = f"{type(exc).__name__}: {str(exc)[:200]}"
        return _redact(text, self._key)  # servers may echo the key in error messages

    @staticmethod
    def _retry_after(exc: Exception) -> float:
        response = getattr(exc, "response", None)
        value = response.headers.get("retry-after") if response is not None else None
        try:
            return max(0.0, float(value)) if value is not None else 0.0
        except ValueError:
            return 0.0
