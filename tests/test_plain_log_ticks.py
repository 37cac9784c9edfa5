"""plain_log_ticks: a log axis labelled with plain numbers, with ticks near both ends of its range."""

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import pytest  # noqa: E402

from uwtutor.widgets.ch04 import plain_log_ticks  # noqa: E402


@pytest.mark.parametrize("limits, expected", [
    ((7.5, 27.0), [10.0, 15.0, 20.0]),                      # less than a decade
    ((13.0, 400.0), [15.0, 20.0, 30.0, 50.0, 70.0, 100.0, 150.0, 200.0, 300.0]),   # the chapter-4 figure's range
    ((1.0, 300.0), [1.0, 2.0, 5.0, 10.0, 20.0, 50.0, 100.0, 200.0]),
    ((0.5, 3000.0), [1.0, 10.0, 100.0, 1000.0]),
])
def test_ticks_cover_the_range_with_plain_labels(limits, expected):
    fig, ax = plt.subplots()
    ax.semilogy([0.0, 1.0], limits)
    ax.set_ylim(*limits)
    plain_log_ticks(ax)
    fig.canvas.draw()
    ticks = [float(t) for t in ax.get_yticks() if limits[0] <= t <= limits[1]]
    assert ticks == pytest.approx(expected)
    labels = [t.get_text() for t in ax.get_yticklabels() if t.get_text()]
    assert labels and not any("10^" in s or "times" in s for s in labels)
    plt.close(fig)


def test_a_narrow_range_still_gets_ticks():
    fig, ax = plt.subplots()
    ax.semilogy([0.0, 1.0], [9.0, 11.0])
    ax.set_ylim(9.0, 11.0)
    plain_log_ticks(ax)
    assert [float(t) for t in ax.get_yticks()] == [9.0, 10.0]
    plt.close(fig)
