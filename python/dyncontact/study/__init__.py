"""Studies that check the schemes in numbers: convergence against the 1D closed form,
work-precision charts and stability maps. One command each::

    python -m dyncontact study convergence [--quick] --out DIR
    python -m dyncontact study work-precision [--quick] --out DIR
    python -m dyncontact study stability [--quick] --out DIR
    python -m dyncontact study all [--quick] --out DIR      # the three + index.md

Each writes CSV, PNG and a summary.md with the findings in numbers. The runs of a study
are independent; :mod:`.sweep` executes them on a local process pool (``--workers N``)
or a Dask cluster (``--scheduler ADDRESS``), with a per-run cache that makes a re-run
resume where it stopped.

The same runner runs the seed's figures (:mod:`.figures`, ``scripts/figures``) and the
benchmark (:mod:`.bench`, ``scripts/bench``, which never takes a timing from the cache).

>>> from dyncontact.study.convergence import run_convergence
>>> report = run_convergence("out/conv", quick=True)           # doctest: +SKIP
>>> report["orders"][0]                                         # doctest: +SKIP
"""

__all__: list[str] = []   # the modules: sweep, analyses, convergence, workprecision,
                          # stability, claims, which, figures, bench, cli
