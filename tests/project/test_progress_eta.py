"""The time-left arithmetic of the progress lines (model/progress.py), on an injected clock."""

import math

import pytest

from bridgeflap.model.progress import Eta, duration_text


class Clock:
    """A clock that moves only when told to."""

    def __init__(self, t=100.0):
        self.t = t

    def __call__(self):
        return self.t


def test_time_left_is_the_rate_so_far_times_the_steps_left():
    clock = Clock()
    eta = Eta(50, clock=clock)
    assert math.isnan(eta.remaining_s(0))
    assert eta.text(0) == "(0 s elapsed)"
    clock.t += 65.0  # 20 steps in 65 s: 3.25 s a step, 30 steps left
    assert eta.elapsed_s() == pytest.approx(65.0)
    assert eta.remaining_s(20) == pytest.approx(97.5)
    assert eta.text(20) == "(1 min 05 s elapsed, about 1 min 38 s left)"
    clock.t += 97.5  # at the end: the total time only
    assert eta.remaining_s(50) == 0.0
    assert eta.text(50) == "(2 min 42 s)"


def test_a_slower_second_half_raises_the_estimate():
    clock = Clock(0.0)
    eta = Eta(4, clock=clock)
    clock.t = 10.0
    first = eta.remaining_s(1)  # 10 s a step, 3 left
    clock.t = 40.0  # the second step took 30 s: 20 s a step so far, 2 left
    assert (first, eta.remaining_s(2)) == (pytest.approx(30.0), pytest.approx(40.0))


@pytest.mark.parametrize("seconds, text", [(0.4, "0 s"), (42, "42 s"), (59.6, "1 min 00 s"),
                                           (185, "3 min 05 s"), (3720, "1 h 02 min"),
                                           (math.nan, "?"), (-1.0, "?")])
def test_durations_read_in_seconds_minutes_and_hours(seconds, text):
    assert duration_text(seconds) == text


def test_an_empty_loop_is_at_its_end():
    eta = Eta(0, clock=Clock())
    assert eta.remaining_s(0) == 0.0 and eta.text(0) == "(0 s)"


def test_a_counted_callback_says_each_step_with_its_time_left():
    from bridgeflap.model.progress import counted

    clock, lines = Clock(0.0), []
    step = counted(3, lines.append, lambda f, k: f"stage {f:.2f} done ({k}/3)", clock=clock)
    clock.t = 20.0
    step(0.5)
    clock.t = 40.0
    step(0.75)
    clock.t = 70.0
    step(1.0)
    assert lines == ["stage 0.50 done (1/3) (20 s elapsed, about 40 s left)",
                     "stage 0.75 done (2/3) (40 s elapsed, about 20 s left)",
                     "stage 1.00 done (3/3) (1 min 10 s)"]
