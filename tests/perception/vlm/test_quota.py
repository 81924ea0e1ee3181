"""The VLM request budget: rate limit and daily quota, persisted atomically so restarts cannot reset it."""

from __future__ import annotations

import json
import logging
import time

from mission.perception_plugins.vlm.quota import QuotaStore, default_state_file

DAY = 86400.0
T0 = 1_700_000_000.0  # 2023-11-14 22:13:20 UTC


def test_calls_are_spaced_by_the_rate_limit(tmp_path):
    store = QuotaStore(tmp_path / "q.json", daily_quota=20, min_interval_s=40.0)
    assert store.refusal(T0) is None
    store.record_call(T0)
    assert store.refusal(T0 + 39.0) == "rate_limited"
    assert store.refusal(T0 + 40.0) is None
    assert store.next_allowed(T0 + 1.0) == T0 + 40.0


def test_the_daily_quota_is_spent_then_renewed_the_next_utc_day(tmp_path):
    store = QuotaStore(tmp_path / "q.json", daily_quota=2, min_interval_s=1.0)
    store.record_call(T0)
    store.record_call(T0 + 10)
    assert store.refusal(T0 + 20) == "quota_exhausted"
    assert store.next_allowed(T0 + 20) is None
    assert store.refusal(T0 + DAY) is None
    assert store.calls_today(T0 + DAY) == 0


def test_a_restarted_store_remembers_calls_and_the_last_call_time(tmp_path):
    path = tmp_path / "q.json"
    first = QuotaStore(path, daily_quota=3, min_interval_s=40.0)
    first.record_call(T0)
    # a crash here: the call was recorded before it was made
    second = QuotaStore(path, daily_quota=3, min_interval_s=40.0)
    assert second.calls_today(T0 + 1) == 1
    assert second.refusal(T0 + 1) == "rate_limited"


def test_the_state_file_is_written_atomically_as_small_json(tmp_path):
    path = tmp_path / "deep" / "dir" / "q.json"
    store = QuotaStore(path, daily_quota=3, min_interval_s=1.0)
    for k in range(3):
        store.record_call(T0 + k)
    assert json.loads(path.read_text()) == {
        "day": "2023-11-14",
        "calls_today": 3,
        "last_call": T0 + 2,
        "recent": [T0, T0 + 1, T0 + 2],
        "not_before": None,
    }
    assert sorted(p.name for p in path.parent.iterdir()) == ["q.json"]  # no temp files left behind


def test_two_stores_sharing_a_file_share_one_budget(tmp_path):
    path = tmp_path / "q.json"
    a = QuotaStore(path, daily_quota=20, min_interval_s=40.0)
    b = QuotaStore(path, daily_quota=20, min_interval_s=40.0)
    a.record_call(T0)
    assert b.refusal(T0 + 5) == "rate_limited"  # b re-reads the file before allowing a call


def test_an_unreadable_state_file_is_reported_once_and_does_not_stop_the_source(tmp_path, caplog):
    path = tmp_path / "q.json"
    path.write_text("{ not json")
    with caplog.at_level(logging.WARNING):
        store = QuotaStore(path, daily_quota=5, min_interval_s=1.0)
        assert store.refusal(T0) is None
        store.refusal(T0)
    assert sum("unreadable" in r.message for r in caplog.records) == 1
    store.record_call(T0)
    assert json.loads(path.read_text())["calls_today"] == 1


def test_a_wall_clock_stepping_back_does_not_block_calls_forever(tmp_path):
    store = QuotaStore(tmp_path / "q.json", daily_quota=20, min_interval_s=40.0)
    store.record_call(T0)
    assert store.refusal(T0 - 3600) == "rate_limited"  # counted from now, so at most one interval
    assert store.refusal(T0 - 3600 + 40) is None


def test_the_default_state_file_lives_in_the_user_cache_dir(monkeypatch, tmp_path):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    assert default_state_file("stub") == tmp_path / "mission" / "vlm_quota_stub.json"


def test_today_is_the_utc_calendar_day():
    store = QuotaStore(None, daily_quota=1, min_interval_s=0.0)
    midnight = (time.time() // DAY + 1) * DAY
    store.record_call(midnight - 1)
    assert store.refusal(midnight - 0.5) == "quota_exhausted"
    assert store.refusal(midnight) is None
