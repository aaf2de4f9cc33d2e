"""Experimental evaluation: parameter sweeps over the execution engine, and reports.

    spec      an experiment file (plans x strategies x delay models x seeds ...) -> cells
    plans     the plans of an experiment: solution files, or instances solved once
    cell      one cell: one simulated run -> one row of the results table
    table     the tidy results table: CSV (appended as cells finish) and Parquet
    sweep     running the cells: one process, all local cores, or a Dask cluster;
              resumable, with a progress bar on stderr
    report    plots and self-contained HTML for a results table or a run folder

`fleetctl experiment` and `fleetctl report` are the thin command-line edges.
"""
