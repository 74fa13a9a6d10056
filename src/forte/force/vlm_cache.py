"""On-disk cache of validated VLM answers, one JSON file per key, written atomically."""

from __future__ import annotations

import hashlib
import json
import logging
import os
import tempfile
from collections.abc import Mapping
from pathlib import Path
from typing import Any
from urllib.parse import urlparse

from forte.exceptions import EstimationError
from forte.force.mass import MassEstimate

log = logging.getLogger(__name__)


def default_cache_dir() -> Path:
    """``$XDG_CACHE_HOME/forte/vlm`` (``~/.cache/forte/vlm`` by default)."""
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "forte" / "vlm"


def server_id(base_url: str) -> str:
    """The server a base URL names: scheme and host lower-cased, no credentials, no trailing slash.

    ``https://API.openai.com/v1/`` and ``https://api.openai.com/v1`` are one server; a user name or
    password in the URL is dropped so that it never reaches a cache file.
    """
    url = urlparse(base_url.strip())
    host = (url.hostname or "").lower()
    port = f":{url.port}" if url.port is not None else ""
    return f"{url.scheme.lower()}://{host}{port}{url.path.rstrip('/')}"


def cache_key(request: Mapping[str, Any]) -> str:
    """sha256 of the canonical JSON (sorted keys, ASCII) of everything that shapes the answer.

    ``request`` holds the server (:func:`server_id`), the model, the prompt version and text, the
    task description, the image's sha256 and the request options (temperature, max_tokens,
    response format): two servers, or one server asked differently, never share an entry.
    """
    payload = json.dumps(request, sort_keys=True, ensure_ascii=True, separators=(",", ":"))
    return hashlib.sha256(payload.encode("utf-8")).hexdigest()


def read_entry(cache_dir: Path, key: str) -> MassEstimate | None:
    """The cached estimate under ``key``, or None when absent or unreadable (logged)."""
    path = Path(cache_dir) / f"{key}.json"
    if not path.is_file():
        return None
    try:
        entry = json.loads(path.read_text(encoding="utf-8"))
        result = MassEstimate.from_dict(entry["estimate"], cached=True)
    except (OSError, ValueError, KeyError, TypeError, EstimationError) as exc:
        log.warning("ignoring unreadable cache entry %s (%s)", path, exc)
        return None
    log.info("VLM estimate for cache key %s read from %s", key[:12], path)
    return result


def write_entry(cache_dir: Path, key: str, entry: dict[str, Any]) -> None:
    """Write ``entry`` under ``key``: temp file then rename, so readers never see half an entry.

    Only public facts belong in ``entry``: never an API key. A failure is logged, not raised: the
    estimate is valid without its cache entry.
    """
    path = Path(cache_dir) / f"{key}.json"
    tmp: str | None = None
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=".tmp-", suffix=".json")
        with os.fdopen(fd, "w", encoding="utf-8") as fh:
            json.dump(entry, fh, indent=2)
        os.replace(tmp, path)
        tmp = None
    except OSError as exc:
        log.warning("could not write the VLM cache entry %s (%s)", path, exc)
    finally:
        if tmp is not None:  # the rename did not happen: leave no temp file behind
            Path(tmp).unlink(missing_ok=True)
