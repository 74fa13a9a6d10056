"""``forte estimate-mass`` and ``forte bench-mass``: payload mass from an image and a description.

Without ``--vlm-base-url`` both use the offline estimator (stated quantities in the description);
with it, any OpenAI-compatible chat-completions server (OpenAI, Ollama, vLLM). The API key is read
from the environment variable named by ``--api-key-env`` and is never printed or cached.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from forte.exceptions import EstimationError, InvalidInputError
from forte.force.estimate import DEFAULT_R_MIN, estimate_payload, radius_from_estimate
from forte.force.mass import MassEstimator
from forte.force.massbench import load_dataset, markdown_table, run_benchmark, summarize_results, write_per_item_csv
from forte.force.offline import OfflineEstimator
from forte.force.vlm import VLMConfig, VLMEstimator
from forte.force.vlm_cache import default_cache_dir


def _add_vlm_options(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("VLM (optional; without --vlm-base-url the offline estimator is used)")
    g.add_argument(
        "--vlm-base-url", metavar="URL", help="OpenAI-compatible server, e.g. https://api.openai.com/v1"
    )
    g.add_argument("--model", default="gpt-4o", help="model name (default gpt-4o, as in the paper)")
    g.add_argument(
        "--api-key-env",
        default="OPENAI_API_KEY",
        metavar="VAR",
        help="environment variable holding the API key (default OPENAI_API_KEY)",
    )
    g.add_argument(
        "--timeout", type=float, default=60.0, metavar="S", help="per-request timeout (default 60 s)"
    )
    g.add_argument("--retries", type=int, default=3, help="retries on 429/5xx/timeouts (default 3)")
    g.add_argument(
        "--backoff",
        type=float,
        default=1.0,
        metavar="S",
        help="first retry wait, doubled each retry (default 1 s)",
    )
    g.add_argument(
        "--cache-dir",
        type=Path,
        metavar="DIR",
        help=f"cache of VLM answers (default {default_cache_dir()})",
    )
    g.add_argument(
        "--no-cache",
        action="store_true",
        help="ask the server every time: neither read nor write the cache of VLM answers",
    )


#: Upper bounds of the numeric options (documented; checked before any work).
MAX_BOOTSTRAP, MAX_WORKERS, MAX_RETRIES, MAX_TIMEOUT_S = 100_000, 64, 20, 3600.0


def _check_numbers(args: argparse.Namespace) -> None:
    """Every numeric option in its range (NaN and inf fail), one line naming the option."""
    from forte.validation import payload_mass

    checks = [("--timeout", args.timeout, 1e-3, MAX_TIMEOUT_S), ("--retries", args.retries, 0, MAX_RETRIES),
              ("--backoff", args.backoff, 0.0, MAX_TIMEOUT_S)]
    if hasattr(args, "r_min"):
        checks += [("--r-min", args.r_min, 0.0, 1e6)]
        if args.mass is not None:
            payload_mass(args.mass, "--mass")
    if hasattr(args, "bootstrap"):
        checks += [("--bootstrap", args.bootstrap, 0, MAX_BOOTSTRAP), ("--workers", args.workers, 1, MAX_WORKERS)]
    for flag, value, low, high in checks:
        if value is not None and not low <= value <= high:
            raise InvalidInputError(f"{flag}: expected a number in [{low:g}, {high:g}], got {value}")


def _vlm_config(args: argparse.Namespace) -> VLMConfig | None:
    _check_numbers(args)
    if not args.vlm_base_url:
        return None
    if args.retries < 0:
        raise InvalidInputError(f"--retries: expected >= 0, got {args.retries}")
    if args.no_cache and args.cache_dir is not None:
        raise InvalidInputError("--no-cache, --cache-dir: give one or the other")
    return VLMConfig(
        base_url=args.vlm_base_url,
        model=args.model,
        api_key_env=args.api_key_env,
        timeout_s=args.timeout,
        max_retries=args.retries,
        backoff_base_s=args.backoff,
        cache=not args.no_cache,
    )


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "estimate-mass",
        help="estimate the payload mass from an image and a task description (JSON)",
        description="Estimate the mass the end effector will carry (paper, Section 4.1) and print it "
        "as JSON: the total, its interval, the objects it is made of (VLM), the source, and the "
        "force-ball radius at rest by the opt-in rule r = max(r_min, 9.81 (high - low) / 2) (the "
        "planner keeps the paper's fixed 10 N).",
    )
    p.add_argument("--image", type=Path, metavar="IMG", help="RGB image (PNG, JPEG, WebP)")
    p.add_argument("--description", metavar="TEXT", help="task description, e.g. 'carry two 1.5 L bottles'")
    p.add_argument("--mass", type=float, metavar="KG", help="known mass: overrides every estimator")
    p.add_argument(
        "--r-min",
        type=float,
        default=DEFAULT_R_MIN,
        metavar="N",
        help="floor of the opt-in radius rule (default 10 N, the paper's fixed radius)",
    )
    _add_vlm_options(p)
    p.set_defaults(func=run_estimate_mass)

    b = sub.add_parser(
        "bench-mass",
        help="evaluate a mass estimator on a CSV data set with the Image2Mass metrics",
        description="Run the estimator on every row of DATASET.csv (columns image, description, "
        "mass_kg; image paths relative to the CSV) and write results.md and items.csv to --out. The "
        "offline estimator ignores masses stated in the descriptions (they would give the answer away).",
    )
    b.add_argument("dataset", type=Path, metavar="DATASET.csv")
    b.add_argument("--out", type=Path, default=Path("mass-bench"), metavar="DIR", help="output folder")
    b.add_argument("--workers", type=int, default=4, metavar="K", help="concurrent requests (default 4)")
    b.add_argument("--quiet", action="store_true", help="no progress on stderr")
    b.add_argument(
        "--bootstrap", type=int, default=1000, metavar="B", help="resamples for r2_ls (default 1000)"
    )
    _add_vlm_options(b)
    b.set_defaults(func=run_bench_mass)


def run_estimate_mass(args: argparse.Namespace) -> int:
    if args.image is None and not args.description and args.mass is None:
        raise InvalidInputError("estimate-mass: give --image, --description or both (or --mass)")
    if args.image is not None:  # checked even when the estimator would not look at it
        from forte.force.images import image_bytes

        image_bytes(args.image, option="--image")
    vlm = _vlm_config(args)
    cache = args.cache_dir if args.cache_dir is not None else (default_cache_dir() if vlm else None)
    try:
        estimate = estimate_payload(args.description, args.image, mass=args.mass, vlm=vlm, cache_dir=cache)
    except EstimationError as exc:
        if args.description or args.image is None:  # the message quotes the description
            raise
        raise EstimationError(f"--image {args.image}: {exc}") from None
    # at rest |a - g| = 9.81 m/s^2; informative only: the planner keeps r = 10 N unless told otherwise
    radius = float(radius_from_estimate([[0.0, 0.0, 0.0]], estimate, args.r_min)[0])
    print(json.dumps({**estimate.to_dict(), "radius_at_rest_n": radius}, indent=2))
    return 0


def run_bench_mass(args: argparse.Namespace) -> int:
    from forte.io.outputs import check_output, output_lock, replace_directory

    _check_numbers(args)
    out = Path(args.out)
    check_output(out)  # before any work: a folder of the user's is never written into
    items = load_dataset(args.dataset)
    vlm = _vlm_config(args)
    estimator: MassEstimator
    if vlm is None:
        # a benchmark scores estimation: a mass stated in the description would be read, not estimated
        estimator = OfflineEstimator(stated_masses=False)
        label = f"offline ({OfflineEstimator.version}, stated masses ignored)"
    else:
        cache = args.cache_dir if args.cache_dir is not None else default_cache_dir()
        estimator = VLMEstimator(vlm, cache)
        label = f"VLM {vlm.model}"
    results = run_benchmark(
        items, estimator, workers=args.workers, progress=None if args.quiet else sys.stderr
    )
    summary = summarize_results(results, n_boot=args.bootstrap)

    def build(tmp: Path) -> None:
        (tmp / "results.md").write_text(markdown_table(summary, label, args.dataset.name), encoding="utf-8")
        write_per_item_csv(results, tmp / "items.csv")
        (tmp / "summary.json").write_text(
            json.dumps({"generator": "forte", "estimator": label, **summary}, indent=2, allow_nan=True),
            encoding="utf-8")

    with output_lock(out):
        replace_directory(build, out)
    m = summary["metrics"]
    print(
        f"{label}: {summary['n_ok']}/{summary['n_items']} estimated, {summary['n_failed']} failed; "
        + ", ".join(f"{k} {v[0]:.3f}" for k, v in m.items())
        + f" on {args.dataset.name} (not comparable with the paper's Table 1, measured on another data set)"
        + f"; wrote {out / 'results.md'} and {out / 'items.csv'}"
    )
    if summary["stated_mass_rows"] and not args.quiet:  # results.md carries the warning either way
        rows = ", ".join(map(str, summary["stated_mass_rows"]))
        print(f"forte: warning: descriptions state a mass in rows {rows} of {args.dataset}", file=sys.stderr)
    return 1 if summary["n_failed"] else 0
