"""plot_field_snapshots' max_snapshots: at most that many, as its docstring says; a
count below 1 is refused."""

from __future__ import annotations

import pytest

from test_plotting import _write_snapshots


@pytest.mark.parametrize("k, times", [
    (1, ["t=2"]),                        # one snapshot, not 2
    (2, ["t=0", "t=2"]),
    (4, ["t=0", "t=0.5", "t=1.5", "t=2"]),
    (9, ["t=0", "t=0.5", "t=1", "t=1.5", "t=2"]),
])
def test_at_most_max_snapshots(tmp_path, k, times):
    from dyncontact.plotting import plot_field_snapshots

    run = _write_snapshots(tmp_path / "run", n=5)
    fig = plot_field_snapshots(run, None, max_snapshots=k)
    assert [t.get_text() for t in fig.axes[0].texts] == times


@pytest.mark.parametrize("k", [0, -3, 1.5, True])
def test_max_snapshots_below_one_is_refused(tmp_path, k):
    from dyncontact.plotting import plot_field_snapshots

    run = _write_snapshots(tmp_path / "run", n=5)
    with pytest.raises(ValueError, match="max_snapshots"):
        plot_field_snapshots(run, None, max_snapshots=k)
