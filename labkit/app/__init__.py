"""Applications of the library: what the ``labkit`` command and the benchmarks run.

Nothing in the library imports from here (``labkit.bundled_data`` is re-exported for the notebooks).

- :mod:`labkit.app.cli` the ``labkit`` command line (``python -m labkit.app.cli`` is the same)
- :mod:`labkit.app.record` a recording file to a rerun ``.rrd`` (read, extract, log)
- :mod:`labkit.app.demo` ``labkit demo``
- :mod:`labkit.app.bench` ``labkit bench``: a recording's throughput, stage by stage
- :mod:`labkit.app.experiments` the evaluation experiments (simulated sets, comparisons, sweeps)
- :mod:`labkit.app.parallel` many recordings on Dask (needs ``labkit[research]``)
- :mod:`labkit.app.data` the bundled recordings in ``data/``
"""
