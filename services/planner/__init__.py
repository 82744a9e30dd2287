"""The construction planner: turns a construction sequence into released tasks and robot assignments.

* :mod:`.sources` — where the sequence comes from (the build's ``sequence.xml``, a user XML, the IFC's 4D
  schedule, or derived from the support graph) and the precedence DAG it gives (:class:`~.sources.Plan`).
* :mod:`.scheduler` — the pure planner core: ready set over the DAG, nearest-idle-robot assignment,
  retry, failure blocking, robot loss, progress, at-least-once resends.
* :mod:`.app` — the Zenoh adapter; :mod:`.cli` — ``bimbot planner``.
"""
