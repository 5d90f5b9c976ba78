"""docs/operations.md lists every setting the server reads, with its default."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from elab.api.settings import REALTIME, Settings
from elab.errors import InvalidInput
from elab.runs.limits import Limits

ROOT = Path(__file__).resolve().parents[2]


def _rows() -> dict[str, str]:
    text = (ROOT / "docs" / "operations.md").read_text(encoding="utf-8")
    return dict(re.findall(r"^\| `(ELAB_[A-Z_]+)` \| ([^|]+) \|", text, re.M))


def test_every_setting_read_from_the_environment_is_documented() -> None:
    source = "".join(
        (ROOT / "backend" / "elab" / f).read_text(encoding="utf-8")
        for f in ("api/settings.py", "runs/limits.py")
    )
    read = set(re.findall(r'"(ELAB_[A-Z_]+)"', source))
    assert read, "no settings found: the pattern is stale"
    assert read <= set(_rows()), sorted(read - set(_rows()))


def test_documented_defaults_are_the_code_defaults() -> None:
    rows, s, d = _rows(), Settings(), Limits()

    def num(name: str) -> float:
        return float(rows[name].split()[0].replace(",", ""))

    assert num("ELAB_MAX_LIVE_RUNS") == d.max_live
    assert num("ELAB_MAX_LIVE_PER_IDENTITY") == d.max_live_per_identity
    assert num("ELAB_MAX_RUNS_PER_IDENTITY") == d.max_runs_per_identity
    assert num("ELAB_MAX_STORAGE_PER_IDENTITY") * (1 << 20) == d.max_storage_per_identity
    assert num("ELAB_RETENTION") == d.retention
    assert num("ELAB_OWNER_GRACE") == d.owner_grace
    assert num("ELAB_OWNER_GONE") == d.owner_gone
    assert num("ELAB_MAX_IDENT_PER_IDENTITY") == s.max_ident_per_identity
    assert num("ELAB_MAX_UPLOADS_PER_IDENTITY") == s.max_uploads_per_identity
    assert num("ELAB_MAX_TOKENS_PER_IDENTITY") == s.max_tokens_per_identity
    assert num("ELAB_MAX_CONTROLLERS_PER_IDENTITY") == s.max_controllers_per_identity
    assert num("ELAB_SECURE_COOKIES") == int(s.secure_cookies)
    assert num("ELAB_SESSION_HOURS") == s.session_hours
    assert num("ELAB_MAX_DURATION") == d.max_duration
    assert num("ELAB_MAX_RUN_SAMPLES") == d.max_samples
    assert num("ELAB_MAX_RECORDING") * (1 << 20) == d.max_recording
    assert num("ELAB_TS_RATIO") == d.ts_ratio
    assert num("ELAB_MAX_BODY") * (1 << 20) == s.max_body
    assert num("ELAB_MAX_UPLOAD") * (1 << 20) == s.max_upload
    assert num("ELAB_MAX_UPLOADS") == s.max_uploads
    assert num("ELAB_WATCHER_FRAMES") == s.watcher_frames
    assert num("ELAB_IDENT_WORKERS") == s.ident_workers
    assert num("ELAB_IDENT_TIMEOUT") == s.ident_timeout
    assert num("ELAB_IDENT_WAIT") == s.ident_wait
    assert num("ELAB_ENGINE_REALTIME") == REALTIME
    assert num("ELAB_ENGINE_NICE") == s.engine_nice
    assert num("ELAB_ENGINE_QUEUE") * (1 << 20) == s.engine_queue
    assert num("ELAB_ENGINE_TIMEOUT") == s.engine_timeout
    assert num("ELAB_ENGINE_STALL") == s.engine_stall
    assert num("ELAB_STORE_RETRY") == s.engine.retry_for
    assert num("ELAB_STORE_PENDING") * (1 << 20) == s.engine.max_pending
    assert num("ELAB_MAX_CODE_RUNS") == s.engine.max_code_runs
    assert num("ELAB_CODE_DEADLINE") == s.engine.code_deadline
    assert num("ELAB_CODE_MISSES") == s.engine.code_misses


def test_the_run_sample_limit_cannot_exceed_what_the_loop_steps() -> None:
    assert Settings.from_env({"ELAB_MAX_RUN_SAMPLES": "36000000"}).limits.max_samples == 36_000_000
    with pytest.raises(InvalidInput) as err:
        Settings.from_env({"ELAB_MAX_RUN_SAMPLES": "36000001"})
    assert err.value.field == "ELAB_MAX_RUN_SAMPLES" and "36000000]" in str(err.value)
