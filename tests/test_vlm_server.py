"""The VLM estimator through the real ``openai`` client against a local chat-completions server.

The server (http.server on 127.0.0.1, port 0) plays a scripted list of replies; every test checks
the documented outcome and, through the autouse ``no_key_leak`` fixture, that the fake API key
appears in no log record and no file written under the test's temporary folder.
"""

from __future__ import annotations

import base64
import json
import logging
import threading
import time
from collections.abc import Iterator
from dataclasses import dataclass, field
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from forte.cli.main import main
from forte.exceptions import EstimationError
from forte.force.vlm import VLMConfig, VLMEstimator
from forte.force.vlm_answer import PROMPT_VERSION

FAKE_KEY = "sk-forte-FAKE-KEY-must-never-leak-8c1f2e"
KEY_ENV = "FORTE_TEST_VLM_KEY"
EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "massbench"
IMAGE = EXAMPLE / "images" / "two_bottles.png"
# the single-object answer of prompt v1, still accepted
GOOD = {
    "object": "two water bottles",
    "mass_kg": 3.1,
    "low_kg": 2.9,
    "high_kg": 3.3,
    "rationale": "2 x 1.5 L",
}


def bottle(mass: float = 1.55, low: float = 1.45, high: float = 1.65, **kw: Any) -> dict[str, Any]:
    return {"description": "1.5 L water bottle", "material": "PET and water", "mass_kg": mass,
            "mass_kg_range": [low, high], "confidence": "high", "occluded": False, **kw}  # fmt: skip


# the answer of prompt v2: one entry per object, the total is summed by forte
OBJECTS = {"objects": [bottle(), bottle(occluded=True)], "reasoning": "two water bottles in the basket"}


@dataclass
class Step:
    """One scripted reply: HTTP status, assistant content (or a raw body), delay before replying."""

    status: int = 200
    content: str | None = json.dumps(OBJECTS)
    delay: float = 0.0
    headers: dict[str, str] = field(default_factory=dict)
    body: dict[str, Any] | None = None


def completion(content: str | None, model: str = "test-model") -> dict[str, Any]:
    return {
        "id": "chatcmpl-test",
        "object": "chat.completion",
        "created": 1700000000,
        "model": model,
        "choices": [
            {
                "index": 0,
                "message": {"role": "assistant", "content": content, "refusal": None},
                "finish_reason": "stop",
                "logprobs": None,
            }
        ],
        "usage": {"prompt_tokens": 10, "completion_tokens": 10, "total_tokens": 20},
    }


class FakeVLM(ThreadingHTTPServer):
    daemon_threads = True

    def __init__(self, steps: list[Step]) -> None:
        super().__init__(("127.0.0.1", 0), Handler)
        self.steps = steps
        self.requests: list[dict[str, Any]] = []
        self.lock = threading.Lock()
        self.stop = threading.Event()

    @property
    def url(self) -> str:
        return f"http://127.0.0.1:{self.server_address[1]}/v1"

    def next_step(self, body: dict[str, Any], headers: dict[str, str], path: str) -> Step:
        with self.lock:
            self.requests.append({"body": body, "headers": headers, "path": path})
            i = len(self.requests) - 1
            return self.steps[min(i, len(self.steps) - 1)]  # the last step repeats

    def handle_error(self, request: Any, client_address: Any) -> None:  # client gave up: fine
        pass


class Handler(BaseHTTPRequestHandler):
    server: FakeVLM

    def do_POST(self) -> None:  # noqa: N802 (http.server's naming)
        length = int(self.headers.get("Content-Length", 0))
        body = json.loads(self.rfile.read(length) or b"{}")
        step = self.server.next_step(body, {k.lower(): v for k, v in self.headers.items()}, self.path)
        if step.delay:
            self.server.stop.wait(step.delay)
        if step.status == 200:
            payload = step.body if step.body is not None else completion(step.content, body.get("model", ""))
        else:
            payload = {"error": {"message": f"scripted {step.status}", "type": "test", "code": None}}
        data = json.dumps(payload).encode()
        try:
            self.send_response(step.status)
            self.send_header("Content-Type", "application/json")
            self.send_header("Content-Length", str(len(data)))
            for k, v in step.headers.items():
                self.send_header(k, v)
            self.end_headers()
            self.wfile.write(data)
        except OSError:  # the client timed out and closed the connection
            pass

    def log_message(self, format: str, *args: Any) -> None:  # keep test output quiet
        pass


@pytest.fixture
def serve() -> Iterator[Any]:
    servers: list[FakeVLM] = []

    def start(*steps: Step) -> FakeVLM:
        srv = FakeVLM(list(steps) or [Step()])
        threading.Thread(target=srv.serve_forever, kwargs={"poll_interval": 0.05}, daemon=True).start()
        servers.append(srv)
        return srv

    yield start
    for srv in servers:
        srv.stop.set()
        srv.shutdown()
        srv.server_close()


@pytest.fixture(autouse=True)
def no_key_leak(
    monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture, tmp_path: Path
) -> Iterator[None]:
    monkeypatch.setenv(KEY_ENV, FAKE_KEY)
    caplog.set_level(logging.DEBUG)  # the openai and httpx debug logs included
    yield
    for record in caplog.records:
        assert FAKE_KEY not in record.getMessage(), record.name
    assert FAKE_KEY not in caplog.text
    for path in tmp_path.rglob("*"):
        if path.is_file():
            assert FAKE_KEY.encode() not in path.read_bytes(), path


def config(url: str, **kw: Any) -> VLMConfig:
    defaults: dict[str, Any] = dict(
        base_url=url,
        model="test-model",
        api_key_env=KEY_ENV,
        timeout_s=1.0,
        max_retries=3,
        backoff_base_s=0.01,
    )
    return VLMConfig(**{**defaults, **kw})


class Sleeps(list[float]):
    def __call__(self, seconds: float) -> None:
        self.append(seconds)
        time.sleep(seconds)


def test_good_answer_request_shape_and_cache(serve: Any, tmp_path: Path) -> None:
    srv = serve(Step())
    est = VLMEstimator(config(srv.url), cache_dir=tmp_path / "cache")
    result = est.estimate("Carry two 1.5 L bottles.", IMAGE)
    assert (result.mass_kg, result.low_kg, result.high_kg) == (3.1, 2.9, 3.3)
    assert result.source == "vlm:test-model" and not result.cached
    assert "two water bottles" in result.rationale and "occluded" in result.rationale
    assert len(result.objects) == 2 and result.objects[1].occluded

    (req,) = srv.requests
    assert req["path"] == "/v1/chat/completions"
    assert req["headers"]["authorization"] == f"Bearer {FAKE_KEY}"  # the key is used, only here
    body = req["body"]
    assert body["model"] == "test-model" and body["temperature"] == 0
    assert body["response_format"]["type"] == "json_schema"
    schema = body["response_format"]["json_schema"]["schema"]
    assert set(schema["required"]) == {"objects", "reasoning"}  # no total: forte sums the objects
    item = schema["properties"]["objects"]["items"]
    assert set(item["required"]) == {"description", "material", "mass_kg", "mass_kg_range", "confidence", "occluded"}
    user = body["messages"][-1]["content"]
    url = next(part["image_url"]["url"] for part in user if part["type"] == "image_url")
    prefix = "data:image/png;base64,"
    assert url.startswith(prefix)
    assert base64.b64decode(url[len(prefix) :]) == IMAGE.read_bytes()
    assert "Carry two 1.5 L bottles." in next(part["text"] for part in user if part["type"] == "text")
    assert "carry" in body["messages"][0]["content"].lower()  # the payload the end effector carries

    files = list((tmp_path / "cache").glob("*.json"))
    assert len(files) == 1
    entry = json.loads(files[0].read_text())
    assert entry["prompt_version"] == PROMPT_VERSION and entry["estimate"]["mass_kg"] == 3.1
    assert len(entry["estimate"]["objects"]) == 2

    again = VLMEstimator(config(srv.url), cache_dir=tmp_path / "cache").estimate(
        "Carry two 1.5 L bottles.", IMAGE
    )
    assert again.cached and again.mass_kg == 3.1 and again.objects == result.objects
    assert len(srv.requests) == 1  # the rerun cost nothing
    VLMEstimator(config(srv.url), cache_dir=tmp_path / "cache").estimate("Carry three 1.5 L bottles.", IMAGE)
    assert len(srv.requests) == 2  # another description is another key


def test_numpy_image_sent_as_png(serve: Any) -> None:
    srv = serve(Step())
    img = np.zeros((8, 8, 3), dtype=np.uint8)
    img[2:6, 2:6] = 200
    VLMEstimator(config(srv.url)).estimate("a box", img)
    user = srv.requests[0]["body"]["messages"][-1]["content"]
    url = next(part["image_url"]["url"] for part in user if part["type"] == "image_url")
    assert base64.b64decode(url.split(",", 1)[1]).startswith(b"\x89PNG")


def test_malformed_json_is_not_retried_nor_cached(serve: Any, tmp_path: Path) -> None:
    srv = serve(Step(content="the mass is about 3 kg"))
    with pytest.raises(EstimationError, match="not valid JSON"):
        VLMEstimator(config(srv.url), cache_dir=tmp_path / "c").estimate("bottles", IMAGE)
    assert len(srv.requests) == 1
    assert not list(tmp_path.rglob("*.json"))


@pytest.mark.parametrize(
    ("answer", "message"),
    [
        ({**GOOD, "mass_kg": -2.0, "low_kg": -3.0}, "mass_kg must be positive"),
        ({**GOOD, "mass_kg": 0, "low_kg": 0}, "mass_kg must be positive"),
        ({**GOOD, "mass_kg": 1e6, "high_kg": 2e6}, "outside the plausible payload range"),
        ({**GOOD, "mass_kg": 5.0}, "low_kg <= mass_kg <= high_kg"),
        ({**GOOD, "mass_kg": "3"}, "mass_kg must be a number"),
        ({k: v for k, v in GOOD.items() if k != "high_kg"}, "'high_kg' is missing"),
        ([3.1], "expected a JSON object"),
    ],
)
def test_invalid_answers(serve: Any, tmp_path: Path, answer: Any, message: str) -> None:
    srv = serve(Step(content=json.dumps(answer)))
    with pytest.raises(EstimationError, match=message):
        VLMEstimator(config(srv.url), cache_dir=tmp_path / "c").estimate("bottles", IMAGE)
    assert len(srv.requests) == 1
    assert not list(tmp_path.rglob("*.json"))


def test_objects_are_summed_in_code_occluded_ones_included(serve: Any, tmp_path: Path) -> None:
    can = {**bottle(0.35, 0.33, 0.37), "description": "330 mL can of cola", "confidence": "Medium"}
    hidden = {**bottle(1.2, 0.8, 2.0), "description": "milk carton under the can", "occluded": True}
    # a total from the model (servers that ignore the schema may add one) is not trusted
    content = {"objects": [bottle(), can, hidden], "reasoning": "basket", "total_mass_kg": 99.0}
    srv = serve(Step(content=json.dumps(content)))
    result = VLMEstimator(config(srv.url), cache_dir=tmp_path).estimate("carry the basket", IMAGE)
    assert result.mass_kg == pytest.approx(1.55 + 0.35 + 1.2, abs=1e-12)
    assert result.total_kg == result.mass_kg
    # the range is the sum of the objects' ranges
    assert result.range_kg == pytest.approx((1.45 + 0.33 + 0.8, 1.65 + 0.37 + 2.0), abs=1e-12)
    assert [o.occluded for o in result.objects] == [False, False, True]
    assert result.objects[1].confidence == "medium"
    assert "milk carton under the can (1.2 kg, occluded)" in result.rationale


def test_single_object_answer_still_accepted(serve: Any) -> None:
    srv = serve(Step(content=json.dumps(GOOD)))
    result = VLMEstimator(config(srv.url)).estimate("bottles", IMAGE)
    assert (result.mass_kg, result.low_kg, result.high_kg) == (3.1, 2.9, 3.3)
    assert [o.description for o in result.objects] == ["two water bottles"]


@pytest.mark.parametrize(
    ("objects", "message"),
    [
        ([], r"objects: expected a non-empty list of objects, got \[\]"),
        ("two bottles", "objects: expected a non-empty list"),
        ([bottle(), 3.1], r"objects\[1\]: expected an object, got 3.1"),
        ([{k: v for k, v in bottle().items() if k != "occluded"}], r"objects\[0\]: field 'occluded' is missing"),
        ([bottle(mass="1.5")], r"objects\[0\].mass_kg must be a number"),
        ([bottle(mass=-1.0, low=-2.0)], r"objects\[0\].mass_kg must be positive"),
        ([bottle(), {**bottle(), "mass_kg_range": [1.4]}], r"objects\[1\].mass_kg_range must be \[low, high\]"),
        ([bottle(high=1.5)], r"objects\[0\]: expected mass_kg_range\[0\] <= mass_kg <= mass_kg_range\[1\]"),
        ([{**bottle(), "confidence": "certain"}], r"objects\[0\].confidence must be low, medium or high"),
        ([{**bottle(), "occluded": "no"}], r"objects\[0\].occluded must be true or false"),
        ([{**bottle(), "description": None}], r"objects\[0\].description must be a string"),
        ([bottle(400.0, 300.0, 500.0), bottle(400.0, 300.0, 500.0)], "add up to 800 kg, outside the plausible"),
    ],
)
def test_malformed_objects_are_rejected(serve: Any, tmp_path: Path, objects: Any, message: str) -> None:
    srv = serve(Step(content=json.dumps({"objects": objects, "reasoning": ""})))
    with pytest.raises(EstimationError, match=message) as info:
        VLMEstimator(config(srv.url), cache_dir=tmp_path / "c").estimate("bottles", IMAGE)
    assert "\n" not in str(info.value) and str(info.value).startswith("VLM answer: ")
    assert len(srv.requests) == 1  # not retried
    assert not list(tmp_path.rglob("*.json"))  # nor cached


def test_500s_then_success(serve: Any) -> None:
    srv = serve(Step(status=500), Step(status=503), Step())
    sleeps = Sleeps()
    result = VLMEstimator(config(srv.url, backoff_base_s=0.01), sleep=sleeps).estimate("bottles", IMAGE)
    assert result.mass_kg == 3.1
    assert len(srv.requests) == 3
    assert sleeps == [0.01, 0.02]  # exponential backoff, base 0.01 s


def test_429_then_success_honours_retry_after(serve: Any) -> None:
    srv = serve(Step(status=429, headers={"Retry-After": "0.05"}), Step())
    sleeps = Sleeps()
    result = VLMEstimator(config(srv.url, backoff_base_s=0.001), sleep=sleeps).estimate("bottles", IMAGE)
    assert result.mass_kg == 3.1 and len(srv.requests) == 2
    assert sleeps == [0.05]


def test_persistent_500_gives_up_after_bounded_retries(serve: Any) -> None:
    srv = serve(Step(status=500))
    with pytest.raises(EstimationError, match=r"no valid response after 3 attempt\(s\), last: HTTP 500"):
        VLMEstimator(config(srv.url, max_retries=2)).estimate("bottles", IMAGE)
    assert len(srv.requests) == 3


def test_timeout_bounded_retries_then_clear_error(serve: Any) -> None:
    srv = serve(Step(delay=2.0))
    start = time.monotonic()
    with pytest.raises(EstimationError, match=r"after 2 attempt\(s\), last: timed out after 0.2 s"):
        VLMEstimator(config(srv.url, timeout_s=0.2, max_retries=1)).estimate("bottles", IMAGE)
    assert time.monotonic() - start < 1.5
    assert len(srv.requests) == 2


def test_slow_server_within_timeout(serve: Any) -> None:
    srv = serve(Step(delay=0.3))
    result = VLMEstimator(config(srv.url, timeout_s=1.0, max_retries=0)).estimate("bottles", IMAGE)
    assert result.mass_kg == 3.1 and len(srv.requests) == 1


def test_client_error_not_retried_and_key_redacted(serve: Any, monkeypatch: pytest.MonkeyPatch) -> None:
    srv = serve(Step(status=401))

    # a server that echoes the key in its error message must not leak it through our error
    def echo(self: Handler) -> None:
        length = int(self.headers.get("Content-Length", 0))
        self.rfile.read(length)
        self.server.next_step({}, {}, self.path)
        data = json.dumps({"error": {"message": f"Incorrect API key provided: {FAKE_KEY}"}}).encode()
        self.send_response(401)
        self.send_header("Content-Type", "application/json")
        self.send_header("Content-Length", str(len(data)))
        self.end_headers()
        self.wfile.write(data)

    monkeypatch.setattr(Handler, "do_POST", echo)
    with pytest.raises(EstimationError, match="HTTP 401") as info:
        VLMEstimator(config(srv.url)).estimate("bottles", IMAGE)
    assert FAKE_KEY not in str(info.value)
    assert len(srv.requests) == 1


def test_connection_refused_is_retried_then_reported(serve: Any) -> None:
    srv = serve(Step())
    url = srv.url
    srv.shutdown()
    srv.server_close()
    with pytest.raises(EstimationError, match=r"after 2 attempt\(s\), last: connection failed"):
        VLMEstimator(config(url, max_retries=1)).estimate("bottles", IMAGE)


def test_missing_key_for_openai_is_refused(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("FORTE_UNSET_KEY", raising=False)
    with pytest.raises(EstimationError, match="set the environment variable FORTE_UNSET_KEY"):
        VLMEstimator(VLMConfig(api_key_env="FORTE_UNSET_KEY"))


def test_corrupt_cache_entry_is_ignored(serve: Any, tmp_path: Path) -> None:
    srv = serve(Step())
    cache = tmp_path / "cache"
    VLMEstimator(config(srv.url), cache_dir=cache).estimate("bottles", IMAGE)
    (entry,) = cache.glob("*.json")
    entry.write_text("{not json")
    result = VLMEstimator(config(srv.url), cache_dir=cache).estimate("bottles", IMAGE)
    assert not result.cached and len(srv.requests) == 2
    assert json.loads(entry.read_text())["estimate"]["mass_kg"] == 3.1  # rewritten


def answer(mass: float) -> Step:
    return Step(content=json.dumps({"objects": [bottle(mass, mass * 0.9, mass * 1.1)], "reasoning": ""}))


def test_two_servers_with_one_model_name_do_not_share_answers(serve: Any, tmp_path: Path) -> None:
    first, second = serve(answer(1.234)), serve(answer(2.5))
    cache = tmp_path / "cache"
    assert VLMEstimator(config(first.url), cache_dir=cache).estimate("bottles", IMAGE).mass_kg == 1.234
    from_second = VLMEstimator(config(second.url), cache_dir=cache).estimate("bottles", IMAGE)
    assert from_second.mass_kg == 2.5 and not from_second.cached
    assert len(first.requests) == 1 and len(second.requests) == 1  # each server was asked
    again = VLMEstimator(config(first.url + "/"), cache_dir=cache).estimate("bottles", IMAGE)
    assert again.cached and again.mass_kg == 1.234 and len(first.requests) == 1  # same server, same answer
    entries = [json.loads(f.read_text()) for f in cache.glob("*.json")]
    assert sorted(e["server"] for e in entries) == sorted([first.url, second.url])
    assert all(e["options"]["temperature"] == 0 and e["image_sha256"] for e in entries)
    assert not list(cache.glob(".tmp-*"))  # written through a temp file and a rename


@pytest.mark.parametrize("change", [{"max_tokens": 512}, {"temperature": 0.7}, {"model": "other-model"}])
def test_other_request_options_ask_again(serve: Any, tmp_path: Path, change: dict[str, Any]) -> None:
    srv = serve(answer(1.0), answer(2.0))
    VLMEstimator(config(srv.url), cache_dir=tmp_path).estimate("bottles", IMAGE)
    result = VLMEstimator(config(srv.url, **change), cache_dir=tmp_path).estimate("bottles", IMAGE)
    assert result.mass_kg == 2.0 and len(srv.requests) == 2
    body = srv.requests[1]["body"]
    assert all(body[k] == v for k, v in change.items())


def test_cache_off_asks_every_time_and_writes_nothing(serve: Any, tmp_path: Path) -> None:
    srv = serve(answer(1.0), answer(2.0))
    est = VLMEstimator(config(srv.url, cache=False), cache_dir=tmp_path / "cache")
    assert [est.estimate("bottles", IMAGE).mass_kg for _ in range(2)] == [1.0, 2.0]
    assert len(srv.requests) == 2 and not (tmp_path / "cache").exists()


def vlm_args(url: str, cache: Path) -> list[str]:
    return [
        "--vlm-base-url", url, "--model", "test-model", "--api-key-env", KEY_ENV,
        "--timeout", "1", "--backoff", "0.01", "--cache-dir", str(cache),
    ]  # fmt: skip


def test_cli_estimate_mass_against_server(
    serve: Any, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    srv = serve(Step(status=500), Step())
    code = main(
        ["estimate-mass", "--image", str(IMAGE), "--description", "carry it", *vlm_args(srv.url, tmp_path)]
    )
    out, err = capsys.readouterr()
    assert code == 0
    result = json.loads(out)
    assert result["mass_kg"] == 3.1 and result["source"] == "vlm:test-model"
    assert result["radius_at_rest_n"] == pytest.approx(max(10.0, 9.81 * 0.2))
    assert FAKE_KEY not in out + err
    assert len(srv.requests) == 2


def test_cli_estimate_mass_server_failure_exit_2(
    serve: Any, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    srv = serve(Step(content=json.dumps({**GOOD, "mass_kg": 0.0, "low_kg": 0.0})))
    code = main(["estimate-mass", "--image", str(IMAGE), "--description", "x", *vlm_args(srv.url, tmp_path)])
    out, err = capsys.readouterr()
    assert code == 2
    assert err.startswith("forte: error: VLM answer: mass_kg must be positive")
    assert FAKE_KEY not in out + err


def test_cli_bench_mass_against_server(
    serve: Any, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # one bad answer among good ones: counted as a failure, the run goes on
    srv = serve(Step(), Step(content="oops"), Step())
    out_dir = tmp_path / "out"
    args = ["bench-mass", str(EXAMPLE / "dataset.csv"), "--out", str(out_dir), "--workers", "3"]
    code = main([*args, *vlm_args(srv.url, tmp_path / "cache")])
    out, err = capsys.readouterr()
    assert code == 1  # a failure was reported
    summary = json.loads((out_dir / "summary.json").read_text())
    assert summary["n_items"] == 8 and summary["n_failed"] == 1 and summary["n_ok"] == 7
    assert "FAILED" in err and "[8/8]" in err
    assert len(srv.requests) == 8
    assert "VLM test-model" in (out_dir / "results.md").read_text()
    assert FAKE_KEY not in out + err

    # rerun: the seven good answers come from the cache, only the failed item is asked again
    code = main([*args, "--quiet", *vlm_args(srv.url, tmp_path / "cache")])
    out, err = capsys.readouterr()
    assert code == 0 and err == ""
    assert len(srv.requests) == 9


def without_cache_dir(args: list[str]) -> list[str]:
    i = args.index("--cache-dir")
    return args[:i] + args[i + 2 :]


def test_cli_no_cache_asks_the_server_again(
    serve: Any, tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))  # where the default cache would go
    srv = serve(answer(1.0), answer(2.0))
    args = ["estimate-mass", "--image", str(IMAGE), "--description", "x", *vlm_args(srv.url, tmp_path / "c")]
    assert main(args) == 0 and main(args) == 0
    assert len(srv.requests) == 1  # the second run came from the cache
    capsys.readouterr()
    assert main([*without_cache_dir(args), "--no-cache"]) == 0
    assert json.loads(capsys.readouterr().out)["mass_kg"] == 2.0
    assert len(srv.requests) == 2 and not (tmp_path / "xdg").exists()
    assert main([*args, "--no-cache"]) == 2
    assert capsys.readouterr().err == "forte: error: --no-cache, --cache-dir: give one or the other\n"


def test_cli_bench_mass_no_cache(
    serve: Any, tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    srv = serve(Step())
    args = ["bench-mass", str(EXAMPLE / "dataset.csv"), "--out", str(tmp_path / "out"), "--quiet"]
    vlm = vlm_args(srv.url, tmp_path / "cache")
    assert main([*args, *vlm]) == 0 and len(srv.requests) == 8
    assert main([*args, *without_cache_dir(vlm), "--no-cache"]) == 0
    assert len(srv.requests) == 16  # every item asked again
    assert not (tmp_path / "xdg").exists()
    capsys.readouterr()


def test_cli_estimate_mass_lists_objects_and_reports_a_bad_one_in_one_line(
    serve: Any, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    srv = serve(Step(), Step(content=json.dumps({"objects": [bottle(), {**bottle(), "mass_kg_range": "wide"}]})))
    args = ["estimate-mass", "--image", str(IMAGE), "--description", "basket", "--no-cache",
            *without_cache_dir(vlm_args(srv.url, tmp_path))]  # fmt: skip
    assert main(args) == 0
    result = json.loads(capsys.readouterr().out)
    assert result["mass_kg"] == 3.1 and [o["occluded"] for o in result["objects"]] == [False, True]
    assert main(args) == 2
    out, err = capsys.readouterr()
    assert out == "" and err == 'forte: error: VLM answer: objects[1].mass_kg_range must be [low, high], got "wide"\n'
