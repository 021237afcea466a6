"""The filter's helper threads (helper_threads.submit): the work's result or its exception at `result()`, and a
forked process (a sweep's worker) served by threads of its own, not its parent's, which it does not have."""

import multiprocessing
import threading

import pytest

from amr_localization.helper_threads import submit


def test_a_task_runs_on_another_thread_and_its_exception_is_raised_where_it_is_collected():
    assert submit(threading.get_ident).result() != threading.get_ident()

    def failing():
        raise ValueError("from the helper")

    with pytest.raises(ValueError, match="from the helper"):
        submit(failing).result()


def _child(queue) -> None:
    queue.put(submit(sum, (1, 2, 3)).result(timeout=20))


def test_a_forked_process_gets_helpers_of_its_own():
    assert submit(int, "7").result() == 7  # the parent's workers exist (and are idle) before the fork
    context = multiprocessing.get_context("fork")
    queue = context.Queue()
    child = context.Process(target=_child, args=(queue,))
    child.start()
    child.join(30)
    assert child.exitcode == 0 and queue.get(timeout=5) == 6


@pytest.mark.parametrize("here", [False, True])
def test_work_started_ahead_gives_its_result_or_its_exception_where_collected_on_either_thread(here):
    from amr_localization.particle_filter import _Ahead

    assert _Ahead(divmod, 7, 2, here=here).result() == (3, 1)
    failed = _Ahead(divmod, 1, 0, here=here)  # no exception yet, on either thread
    with pytest.raises(ZeroDivisionError):
        failed.result()
