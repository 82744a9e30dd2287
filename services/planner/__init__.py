"""The construction planner: turns a construction sequence into released tasks and robot assignments.

* :mod:`.sources` — where the sequence comes from (the build's ``sequence.xml``, a user XML, the IFC's 4D
  schedule, or derived from the support graph) and the precedence DAG it gives (:class:`~.sources.Plan`).
* :mod:`.scheduler` — the pure planner core (:class:`~.scheduler.PlannerCore`): ready set over the DAG,
  assignment, retry, failure blocking, robot loss, progress, at-least-once resends; one part per step
  (:mod:`.release`, :mod:`.dispatch`, :mod:`.follow_up`, :mod:`.give_backs`, :mod:`.failures`,
  :mod:`.watchdog`, :mod:`.quiet`) on a shared :mod:`.planner_state` and :mod:`.outbox`.
* :mod:`.app` — the Zenoh adapter; :mod:`.cli` — ``bimbot planner``.
"""
