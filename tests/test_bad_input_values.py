"""Values the scene reader accepts (finite, in their key's range) whose numbers overflow
on the mesh: a run started from them would begin at e_total(0) = Infinity or NaN, or go
NaN at its first contact, and be reported as a numerical failure (exit 3). They are bad
input, refused at set-up through both entry points with exit status 2 and the same one
line naming the scene file and the key (fortran/fem/model.f90: check_gamma0,
model_check_initial; fortran/run/simulation.f90: energy_limit, whose blow-up limit
would otherwise be Infinity and the test off)."""

from __future__ import annotations

import re

import pytest

from conftest import stderr_line
from test_scene import BadCase, write_case

#: Exit status of bad input (SPEC section 3).
EXIT_BAD_INPUT = 2

#: t_end = 0: the checks run at set-up, before any step.
AT_SET_UP = "&scheme t_end = 0 /\n"

CASES = [
    BadCase("velocity_1e308", "&initial kind = 'velocity', velocity = 0.0, -1e308 /\n",
            "&initial velocity", "the initial kinetic energy v0.M v0 / 2 is not finite"),
    BadCase("velocity_with_density",
            "&initial kind = 'velocity', velocity = 1e150, 0.0 /\n"
            "&material density = 1e100 /\n",
            "&initial velocity", "&material density = 1.0E+100"),
    BadCase("amplitude_1e200", "&initial amplitude = 1e200 /\n", "&initial amplitude",
            "the initial elastic and contact energy of kind = 'compressed_bar' is not finite"),
    BadCase("young_1e308", "&material young = 1e308 /\n", "&material young",
            "overflows the stiffness matrix K"),
    BadCase("gravity_times_density", "&material gravity = 0.0, -1e300, density = 1e300 /\n",
            "&material gravity", "the load rho g overflows"),
    BadCase("gravity_load_energy", "&material gravity = 0.0, -1e200 /\n",
            "&material gravity", "the load's energy 1/2 L.(K + M/t_end^2)^-1 L overflows"),
    BadCase("blowup_times_scale",
            "&initial kind = 'velocity', velocity = 0.0, -1e10, amplitude = 0.0 /\n"
            "&scheme blowup = 1e300, t_end = 0 /\n",
            "&scheme blowup", "x the energy scale 4.833E+018 overflows, which would turn the "
            "blow-up test off; give blowup <= 3.7E+288"),
    BadCase("gamma0_subnormal_theta0", "&contact theta = 0, gamma0 = 1e-320 /\n",
            "&contact gamma0", "1 / gamma_N overflows on this mesh; use gamma0 = 1.0E+001"),
    BadCase("gamma0_subnormal_penalty", "&contact method = 'penalty', gamma0 = 1e-320 /\n",
            "&contact gamma0", "1 / gamma_N overflows on this mesh; use gamma0 = 1.0E+000"),
    BadCase("gamma0_huge", "&contact gamma0 = 1e308 /\n", "&contact gamma0",
            "gamma_N = gamma0 / h_T or 1 / gamma_N overflows"),
]


def refused_line(run_exe, run_cli, path) -> str:
    """The one stderr line of both entry points for a bad scene (the same line)."""
    lines = [stderr_line(res, EXIT_BAD_INPUT)
             for res in (run_exe(path, cwd=path.parent), run_cli("run", path, cwd=path.parent))]
    assert lines[0] == lines[1], lines
    assert not (path.parent / "out" / "trace.csv").exists()
    return lines[0]


@pytest.mark.parametrize("case", CASES, ids=lambda c: c.id)
def test_overflowing_value_is_bad_input(run_exe, run_cli, case, tmp_path):
    at_set_up = "" if "&scheme" in case.content else AT_SET_UP   # (t_end = 0 given)
    path = write_case(case._replace(content=case.content + at_set_up), tmp_path)
    line = refused_line(run_exe, run_cli, path)
    assert f"{path}: {case.where}: " in line, (line, case.where)
    assert case.what in line, (line, case.what)


def test_just_below_overflow_runs(run_exe, tmp_path):
    """The largest velocity whose kinetic energy is finite on the bar runs its steps (the
    check refuses only a state that overflows)."""
    path = tmp_path / "fast.nml"
    path.write_text("&initial kind = 'velocity', velocity = 0.0, -1e150 /\n"
                    "&scheme t_end = 0.005 /\n")
    res = run_exe(path, cwd=tmp_path)
    assert res.returncode == 0, res.stderr


BOUND = re.compile(r"indefinite below gamma0 = (\S+) \(element bound\)")


def test_subnormal_gamma0_reports_the_element_bound(run_exe, run_cli, tmp_path):
    """The element bound depends on the mesh and the material only: a subnormal gamma0
    (gamma_N = gamma0 / h_T, whose |F| / gamma_N overflows) gets the same finite bound,
    and the same suggestion, as gamma0 = 1e-3."""
    found = {}
    for gamma0 in ("1e-320", "1e-3"):
        path = tmp_path / f"g{gamma0}.nml"
        path.write_text(f"&contact gamma0 = {gamma0} /\n" + AT_SET_UP)
        line = refused_line(run_exe, run_cli, path)
        assert f"{path}: &contact gamma0: " in line, line
        bound = BOUND.search(line)
        assert bound, line
        found[gamma0] = (float(bound.group(1)), line.split("use gamma0 = ")[1])
    assert found["1e-320"] == found["1e-3"]
    assert 0.0 < found["1e-3"][0] < float("inf")
