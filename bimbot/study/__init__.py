"""``bimbot study``: many runs of one build over a grid of fleets, sequences and seeds, and what they say.

Pure parts first: the grid and each run's command line (:mod:`.grid`), a run's row from its report
(:mod:`.rows`), the table and the plot over the rows (:mod:`.summary`). Then the adapters: one run as a
``bimbot run`` process (:mod:`.execute`), the runs on Dask (:mod:`.cluster`) and the command (:mod:`.cli`).
"""
