"""The start-up check of the CPU: a build for x86-64-v3 (-Dsimd=auto) on a CPU without it
stops with one line naming what the build uses, what the CPU lacks and the rebuild with
-Dsimd=portable, exit 4, instead of SIGILL. Without old hardware: the checks take the CPU's
features as input (fortran/app/cpu_check.c's dc_cpu_lacking, core.cpu_lacks), a C program
gives them made-up CPUs, and the Python command line runs with /proc/cpuinfo's flags
replaced by an older CPU's."""

from __future__ import annotations

import json
import re
import shlex
import subprocess
import sys

import pytest

from conftest import EXE, ROOT, SUBPROCESS_TIMEOUT

from dyncontact import cli, core

BUILD = ROOT / "build"
#: The flags of /proc/cpuinfo of a CPU with x86-64-v3 (a Zen 2 core, trimmed).
V3_FLAGS = set("fpu cmov mmx fxsr sse sse2 pni pclmulqdq ssse3 fma cx16 sse4_1 sse4_2 movbe "
               "popcnt aes xsave avx f16c lahf_lm abm bmi1 avx2 bmi2".split())
#: A Sandy Bridge's (AVX but no AVX2, BMI, F16C, LZCNT, MOVBE).
SANDY_BRIDGE_FLAGS = set("fpu cmov mmx fxsr sse sse2 pni pclmulqdq ssse3 cx16 sse4_1 sse4_2 "
                         "popcnt aes xsave avx lahf_lm".split())


def test_the_c_check_on_made_up_cpus():
    exe = BUILD / "tests" / "test_cpu_check"
    if not exe.exists():
        pytest.skip(f"{exe} not built (scripts/setup builds it)")
    proc = subprocess.run([str(exe)], capture_output=True, text=True, timeout=SUBPROCESS_TIMEOUT)
    assert proc.returncode == 0, proc.stdout + proc.stderr


def test_both_checks_ask_for_the_same_features():
    text = (ROOT / "fortran" / "app" / "cpu_check.c").read_text()
    table = re.search(r"dc_v3_features\[DC_V3_FEATURES\] = \{(.*?)\};", text, re.S).group(1)
    c_names = re.findall(r'"([^"]+)"', table)
    assert c_names == [name for name, _ in core.V3_FEATURES]
    supports = re.findall(r'have\[(\d+)\] = __builtin_cpu_supports\("([^"]+)"\)', text)
    assert [(int(i), n) for i, n in supports] == list(enumerate(c_names))
    assert "fma" not in c_names   # the build compiles with -mno-fma


def test_the_program_check_is_compiled_for_the_baseline():
    """The check must not itself use an instruction of x86-64-v3: its compile command's
    last -march is the baseline's, and it is compiled in (DC_CPU_CHECK_ISA) exactly when
    the core is built for x86-64-v3."""
    db = BUILD / "compile_commands.json"
    if not db.exists():
        pytest.skip("no build/compile_commands.json (scripts/setup makes it)")
    from dyncontact._version import __isa__
    commands = [e["command"] for e in json.loads(db.read_text())
                if e["file"].endswith("fortran/app/cpu_check.c")]
    assert len(commands) == 1
    args = shlex.split(commands[0])
    marches = [a for a in args if a.startswith("-march=")]
    if __isa__ == "x86-64-v3":
        assert marches[-1] == "-march=x86-64", args
        assert '-DDC_CPU_CHECK_ISA="x86-64-v3"' in args, args
        nm = subprocess.run(["nm", str(EXE)], capture_output=True, text=True)
        if nm.returncode == 0:
            assert " dc_cpu_check\n" in nm.stdout   # linked whole into the program
    else:
        assert "-march=x86-64-v3" not in marches
        assert not any(a.startswith("-DDC_CPU_CHECK_ISA") for a in args)


def test_this_cpu_passes_the_check(run_exe):
    """The machine that built the program runs it (the check lets a CPU with the features
    through)."""
    res = run_exe("--version")
    assert res.returncode == 0 and res.stdout.startswith("dyncontact "), res.stderr


@pytest.mark.parametrize("isa, flags, lacking", [
    ("x86-64-v3", V3_FLAGS, None),
    ("x86-64-v3", V3_FLAGS - {"fma"}, None),          # not used (-mno-fma)
    ("x86-64-v3", SANDY_BRIDGE_FLAGS, "avx2, bmi, bmi2, f16c, lzcnt, movbe"),
    ("x86-64-v3", V3_FLAGS - {"avx2"}, "avx2"),
    ("x86-64", SANDY_BRIDGE_FLAGS, None),             # the portable build
    ("x86-64", set(), None),
    ("x86-64-v3", None, None),                        # no /proc/cpuinfo: nothing known
])
def test_cpu_lacks(isa, flags, lacking):
    said = core.cpu_lacks(isa, flags)
    if lacking is None:
        assert said is None
    else:
        assert f"lacks {lacking};" in said
        assert "x86-64-v3" in said and "-Dsimd=portable" in said and "\n" not in said


def test_the_python_cli_stops_before_the_extension_on_an_older_cpu(monkeypatch, capsys,
                                                                   tmp_path):
    """With the flags of a CPU without AVX2 and the build's level x86-64-v3, `python -m
    dyncontact run` says so in one line, exit 4, and does not import the extension."""
    import dyncontact._version as version

    imported = []

    class Watch:
        """Notes any import of dyncontact._core while the test runs."""

        def find_spec(self, name, path=None, target=None):
            if name == "dyncontact._core":
                imported.append(name)
            return None

    monkeypatch.setattr(version, "__isa__", "x86-64-v3")
    monkeypatch.setattr(core, "_cpu_flags", lambda: SANDY_BRIDGE_FLAGS)
    monkeypatch.delitem(sys.modules, "dyncontact._core", raising=False)
    monkeypatch.setattr(sys, "meta_path", [Watch()] + sys.meta_path)
    scene = ROOT / "scripts" / "scenes" / "bar1d.nml"
    code = cli.main(["run", str(scene), "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert code == 4, err
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith("dyncontact: this build of the core uses x86-64-v3")
    assert "lacks avx2, bmi, bmi2, f16c, lzcnt, movbe;" in lines[0]
    assert "-Dsimd=portable" in lines[0]
    assert imported == []
