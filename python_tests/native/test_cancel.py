# SPDX-License-Identifier: GPL-3.0-or-later
"""Cancellation through the Python API: a CancelToken raised from another thread stops a running
native call (the GIL is released meanwhile) with texsynth_native.Cancelled; a raised token stops a
call before it does anything. Latency figures: python_tests/bench/bench_cancel.py."""
import sys
import threading

import pytest
import paths

sys.path.insert(0, paths.HOSTILE)
import make_corpus  # noqa: E402
import worker  # noqa: E402

tn = pytest.importorskip("texsynth_native")


@pytest.fixture(scope="module")
def sample():
    return tn.preprocess(make_corpus.sample_pixels(), **make_corpus.SMALL_PARAMS)


def test_raised_token_stops_preprocess_and_synthesis(sample):
    token = tn.CancelToken()
    assert not token.cancelled
    token.cancel()
    assert token.cancelled
    with pytest.raises(tn.Cancelled):
        tn.preprocess(make_corpus.sample_pixels(), cancel=token, **make_corpus.SMALL_PARAMS)
    mesh = worker.huge_triangle_grid(20)
    with pytest.raises(tn.Cancelled):
        tn.synthesize_jumpmap(sample, *mesh, scale=1.0, cancel=token)
    # Without the token the same call completes: the token, not the input, stopped it.
    assert tn.synthesize_jumpmap(sample, *mesh, scale=1.0)["base_uv"].shape == (len(mesh[1]), 2)


def test_cancel_from_another_thread_stops_a_running_synthesis(sample):
    mesh = worker.huge_triangle_grid(700)  # ~1M triangles: well over a second of work
    token = tn.CancelToken()
    outcome = {}
    started = threading.Event()

    def run():
        started.set()
        try:
            outcome["result"] = tn.synthesize_jumpmap(sample, *mesh, scale=0.5, cancel=token)
        except tn.Cancelled as error:
            outcome["cancelled"] = error

    thread = threading.Thread(target=run)
    thread.start()
    started.wait()
    token.cancel()  # runs while the worker is inside native code: the GIL must be released
    thread.join(timeout=600)
    assert not thread.is_alive()
    assert "cancelled" in outcome and "result" not in outcome


def test_token_stops_texton_synthesis_before_and_during_the_run(sample):
    pixels = make_corpus.sample_pixels()
    raised = tn.CancelToken()
    raised.cancel()
    small = worker.huge_triangle_grid(20)
    with pytest.raises(tn.Cancelled):
        tn.synthesize_texton(sample, pixels, *small, scale=1.0, cancel=raised)
    assert tn.synthesize_texton(sample, pixels, *small, scale=1.0)["base_uv"].shape == (len(small[1]), 2)

    mesh = worker.huge_triangle_grid(300)  # 180k triangles: about a second of searching
    for kwargs in ({}, {"seeds_per_component": 16}):  # sequential growth, then regions grown in parallel
        token, outcome, started = tn.CancelToken(), {}, threading.Event()

        def run():
            started.set()
            try:
                outcome["result"] = tn.synthesize_texton(sample, pixels, *mesh, scale=0.05, cancel=token, **kwargs)
            except tn.Cancelled as error:
                outcome["cancelled"] = error

        thread = threading.Thread(target=run)
        thread.start()
        started.wait()
        token.cancel()
        thread.join(timeout=600)
        assert not thread.is_alive()
        assert "cancelled" in outcome and "result" not in outcome, kwargs


def test_bad_token_is_a_clear_error(sample):
    with pytest.raises(ValueError, match="CancelToken"):
        tn.synthesize_jumpmap(sample, *worker.huge_triangle_grid(2), scale=1.0, cancel=object())
    assert issubclass(tn.Cancelled, RuntimeError)
