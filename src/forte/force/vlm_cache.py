"""On-disk cache of validated VLM answers, one JSON file per key, written atomically."""

from __future__ import annotations

import hashlib
import json
import logging
import os
import tempfile
from pathlib import Path
from typing import Any

from forte.exceptions import EstimationError
from forte.force.estimate import MassEstimate
from forte.force.vlm_answer import PROMPT_VERSION

log = logging.getLogger(__name__)


def default_cache_dir() -> Path:
    """``$XDG_CACHE_HOME/forte/vlm`` (``~/.cache/forte/vlm`` by default)."""
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "forte" / "vlm"


def cache_key(image_sha256: str, description: str, model: str) -> str:
    """sha256 over the prompt version, the model, the description and the image's sha256."""
    payload = json.dumps([PROMPT_VERSION, model, description, image_sha256], ensure_ascii=True)
    return hashlib.sha256(payload.encode("utf-8")).hexdigest()


def read_entry(cache_dir: Path, key: str) -> MassEstimate | None:
    """The cached estimate under ``key``, or None when absent or unreadable (logged)."""
    path = Path(cache_dir) / f"{key}.json"
    if not path.is_file():
        return None
    try:
        entry = json.loads(path.read_text(encoding="utf-8"))
        est = entry["estimate"]
        result = MassEstimate(
            float(est["mass_kg"]), float(est["low_kg"]), float(est["high_kg"]),
            str(est["source"]), str(est.get("rationale", "")), cached=True,
        )  # fmt: skip
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
