"""``bimbot run``: a converted build built by every service as its own process, watched and reported.

The entry is :mod:`bimbot.run.main` (its options, :func:`~bimbot.run.build.run_build`, the summary and the
exit code). The parts, in the order a run meets them:

* :mod:`.options`: every option, declared once (:data:`~.options.SERVICE_OPTIONS`: which services get it);
* :mod:`.commands`: each service's command line, built from those declarations;
* :mod:`.preflight`: each command line checked by its service's own parser before anything starts;
* :mod:`.build`: the run folder, the router, the services, the wait and the end;
* :mod:`.monitor` (states as hints, twins as truth), :mod:`.loop` and :mod:`.watchdog` (how a run ends),
  :mod:`.restarts`, :mod:`.progress` (the terminal), :mod:`.as_built` (the end-of-run audit);
* :mod:`.settings`, :mod:`.summary`, :mod:`.table`: what the report and the summary say of the run;
* :mod:`.outcome`: a finished run's outcome read back from its report (benches compare runs);
* :mod:`.stability`: ``--check-stability``, the plan replayed without robots.

Nothing is imported here, so a part loads without the rest (the fork server's input check imports only
:mod:`.options` and :mod:`.preflight`).
"""
