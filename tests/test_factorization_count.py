"""summary.json's `factorizations` against the numeric factorizations a run actually
makes, counted outside the core: a small library preloaded into build/dyncontact
(LD_PRELOAD) counts the calls to CHOLMOD's cholmod_factorize and UMFPACK's
umfpack_di_numeric and writes the count when the process exits. The core's CHOLMOD shim
factorizes by ranges of rows (several cholmod_rowfac calls a factorization) unless
DYNCONTACT_FACTOR_RANGES = 0, which makes each LDL^T one cholmod_factorize call: set
here, so one call is one factorization.

The cases: the θ-scheme with a redistributed mass, whose definiteness check factorizes
the node matrix S′ (or M′ itself) besides J0, direct and CG, in 1D, 2D and 3D; and, to
show the counter agrees where the count was already right, the θ-scheme with a
consistent mass and HHT with a redistributed and a lumped mass. With gravity the set-up
also factorizes K + M/t_end² for the blow-up limit's load energy, outside the scheme:
summary.json counts it apart (`setup_factorizations`, 1), and the two counts together are
the calls made (HHT, the θ-scheme with CG, and central, whose automatic step makes the
set-up's factorization come after the scheme's)."""

from __future__ import annotations

import os
import subprocess

import pytest

from conftest import ROOT, SUBPROCESS_TIMEOUT

import dyncontact
from dyncontact import Scene

COUNTER_C = r"""
#define _GNU_SOURCE
#include <dlfcn.h>
#include <stdio.h>
#include <stdlib.h>

static long calls = 0;

int cholmod_factorize(void *a, void *l, void *c)
{
    static int (*real)(void *, void *, void *) = NULL;
    if (real == NULL) real = (int (*)(void *, void *, void *)) dlsym(RTLD_NEXT, "cholmod_factorize");
    calls++;
    return real(a, l, c);
}

int umfpack_di_numeric(const int *ap, const int *ai, const double *ax, void *sym,
                       void **num, const double *control, double *info)
{
    static int (*real)(const int *, const int *, const double *, void *, void **,
                       const double *, double *) = NULL;
    if (real == NULL)
        real = (int (*)(const int *, const int *, const double *, void *, void **,
                        const double *, double *)) dlsym(RTLD_NEXT, "umfpack_di_numeric");
    calls++;
    return real(ap, ai, ax, sym, num, control, info);
}

__attribute__((destructor)) static void write_count(void)
{
    const char *path = getenv("FACTOR_COUNT_FILE");
    FILE *f;
    if (path == NULL) return;
    f = fopen(path, "w");
    if (f == NULL) return;
    fprintf(f, "%ld\n", calls);
    fclose(f);
}
"""

#: (scene file or None for the seed's 2D bar, scheme, mass, solver, gravity or None)
CASES = [(scn, "theta", "redistributed", solver, None)
         for scn in ("bar1d", None, "bar3d_hht") for solver in ("direct", "cg")]
CASES += [(None, "theta", "consistent", "direct", None),
          (None, "hht", "redistributed", "direct", None),
          (None, "hht", "lumped", "direct", None),
          ("bar3d_hht", "hht", "redistributed", "cg", None)]
# a load: the set-up's factorization of K + M/t_end^2 (setup_factorizations), for an
# implicit scheme, and for central with its automatic step (made after the scheme's)
CASES += [(None, "hht", "consistent", "direct", "0.0, -9.81"),
          ("bar3d_hht", "theta", "redistributed", "cg", "0.0, 0.0, -9.81"),
          (None, "central", "lumped", "direct", "0.0, -9.81")]


@pytest.fixture(scope="module")
def counter(tmp_path_factory) -> str:
    """The counting library, compiled with the system's C compiler (which the build
    needs anyway)."""
    d = tmp_path_factory.mktemp("counter")
    (d / "count.c").write_text(COUNTER_C)
    lib = d / "libcount.so"
    res = subprocess.run(["cc", "-shared", "-fPIC", "-O1", "-o", str(lib), str(d / "count.c"),
                          "-ldl"], capture_output=True, text=True)
    assert res.returncode == 0, res.stderr
    return str(lib)


@pytest.mark.parametrize("scn, scheme, mass, solver, gravity", CASES)
def test_summary_counts_the_factorizations_made(scn, scheme, mass, solver, gravity, counter,
                                                exe, tmp_path):
    s = Scene.read(ROOT / "scripts" / "scenes" / f"{scn}.nml") if scn else Scene()
    s.set("scheme.name", scheme)
    s.set("scheme.mass", mass)
    s.set("solver.kind", solver)
    s.set("scheme.t_end", 0.05)
    if scheme == "theta":
        s.set("scheme.theta", 0.6)     # (0.5 warns with a redistributed mass)
    if scheme == "central":
        s.set("scheme.dt", 0)          # the step the scheme chooses
    if gravity is not None:
        s.set("material.gravity", gravity)
    s.set("output.dir", str(tmp_path / "out"))
    s.write(tmp_path / "s.nml")
    env = dict(os.environ, LD_PRELOAD=counter, DYNCONTACT_FACTOR_RANGES="0",
               FACTOR_COUNT_FILE=str(tmp_path / "count"))
    env.pop("PYTHONPATH", None)
    res = subprocess.run([str(exe), str(tmp_path / "s.nml")], cwd=tmp_path, env=env,
                         capture_output=True, text=True, timeout=SUBPROCESS_TIMEOUT)
    assert res.returncode == 0, res.stderr
    made = int((tmp_path / "count").read_text())
    summary = dyncontact.core.read_summary(tmp_path / "out")
    counted = summary["factorizations"] + summary["setup_factorizations"]
    assert counted == made, (summary["factorizations"], summary["setup_factorizations"], made)
    assert summary["setup_factorizations"] == (0 if gravity is None else 1)
    if scheme == "theta" and mass == "redistributed":
        # the check's factorization and J0's (none for J0 with CG)
        assert summary["factorizations"] == (1 if solver == "cg" else 2), made
