"""A sweep grid that names one case twice: the sweep runs it once and gives its record to
each task; a study's --schemes that names a scheme twice is refused (its rows would be
counted twice in the fits, the tables and the CSVs)."""

from __future__ import annotations

import os

import pytest

from conftest import stderr_line
from dyncontact.study.common import scheme_list


def test_scheme_list_refuses_a_key_given_twice():
    with pytest.raises(ValueError, match="more than once: newmark$"):
        scheme_list("newmark,pc,newmark")
    assert [s.key for s in scheme_list("newmark,pc")] == ["newmark", "pc"]


def test_study_schemes_given_twice_is_refused_naming_it(run_cli, tmp_path):
    line = stderr_line(run_cli("study", "convergence", "--quick", "--no-progress",
                               "--schemes", "newmark,pc,newmark", "--out",
                               str(tmp_path / "s")), 2, "dyncontact study: ")
    assert "--schemes" in line and "newmark" in line, line
    assert sorted(os.listdir(tmp_path)) == []
