import threading
import time

import pytest

from viewer_slam.rerun_adapter.background import RecordingThread


def test_calls_run_in_order_on_one_thread_other_than_the_callers():
    seen, threads = [], set()

    def note(item):
        time.sleep(0.001 if item % 7 == 0 else 0.0)  # uneven work must not reorder anything
        seen.append(item)
        threads.add(threading.current_thread().name)

    with RecordingThread(max_pending=4) as background:
        sink = background.sink(note)
        for item in range(200):
            sink(item)
        background.drain()
        assert seen == list(range(200))
    assert threads == {"viewslam-recorder"}


def test_drain_waits_for_every_queued_call_and_close_runs_what_is_left():
    done = []
    background = RecordingThread()
    for item in range(5):
        background.submit(lambda item=item: (time.sleep(0.01), done.append(item)))
    background.drain()
    assert done == [0, 1, 2, 3, 4]
    background.submit(done.append, 5)
    background.close()
    assert done == [0, 1, 2, 3, 4, 5]


def test_a_failing_call_is_raised_in_the_callers_thread_and_nothing_after_it_runs():
    done = []

    def fail():
        raise ValueError("recorder broke")

    with RecordingThread() as background:
        background.submit(done.append, 1)
        background.submit(fail)
        background.submit(done.append, 2)
        with pytest.raises(ValueError, match="recorder broke"):
            background.drain()
        with pytest.raises(ValueError, match="recorder broke"):
            background.submit(done.append, 3)
    assert done == [1]


def test_a_full_queue_holds_the_caller_back_instead_of_growing():
    release = threading.Event()
    with RecordingThread(max_pending=2) as background:
        background.submit(release.wait)
        background.submit(lambda: None)
        background.submit(lambda: None)  # the thread holds the first call: two wait
        blocked = threading.Thread(target=background.submit, args=(lambda: None,))
        blocked.start()
        blocked.join(0.2)
        assert blocked.is_alive()
        release.set()
        blocked.join(5)
        assert not blocked.is_alive()
