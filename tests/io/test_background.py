"""BackgroundWriter: order, bounded queue, a failed write surfaces as OutputError."""

import threading

import pytest

from tissuempm.io.background import BackgroundWriter, OutputError


def test_jobs_run_in_submission_order():
    done = []
    w = BackgroundWriter(depth=2)
    for k in range(20):
        w.submit(f"job {k}", done.append, k)
    w.close()
    assert done == list(range(20))


def test_queue_is_bounded():
    """With one job being written and ``depth`` waiting, the next submit blocks until the writer frees a slot."""
    release = threading.Event()
    w = BackgroundWriter(depth=1)
    w.submit("slow", release.wait)  # taken by the thread
    while w._queue.qsize():  # wait until the thread holds the slow job
        pass
    w.submit("queued", lambda: None)
    started, submitted = threading.Event(), threading.Event()

    def third():
        started.set()
        w.submit("blocked", lambda: None)
        submitted.set()

    t = threading.Thread(target=third)
    t.start()
    started.wait()
    assert not submitted.wait(0.2)  # the queue is full: the submit waits
    release.set()
    assert submitted.wait(5)
    t.join()
    w.close()


def test_failed_write_stops_the_output_with_its_name():
    done = []

    def fail():
        raise OSError("No space left on device")

    w = BackgroundWriter(depth=2)
    w.submit("frames/particles_00003.vtu", fail)
    with pytest.raises(OutputError, match=r"particles_00003\.vtu failed: OSError: No space left"):
        w.drain()
    with pytest.raises(OutputError):
        w.submit("checkpoint.h5", done.append, 1)
    with pytest.raises(OutputError):
        w.close()
    assert done == []


def test_quiet_close_after_a_failure_keeps_the_earlier_writes():
    """A run stopping on another error closes quietly: what was queued before is written."""
    done = []
    w = BackgroundWriter(depth=4)
    w.submit("a", done.append, 1)
    w.submit("b", done.append, 2)
    w.close(quiet=True)
    w.close(quiet=True)  # twice: harmless
    assert done == [1, 2]
