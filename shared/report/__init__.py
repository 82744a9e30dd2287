"""The construction report, in one place for the run (``bimbot run``) and the observer (``bimbot observe``).

:mod:`.collector` gathers what a run heard on the bus into ``report.json`` (:class:`~.collector.
ReportCollector`; :class:`~.collector.RunEnding`: how a run ended); :mod:`.robots`, :mod:`.placements`,
:mod:`.methods`, :mod:`.fleet` and :mod:`.totals` build its parts; :mod:`.png` draws ``report.png`` (with
:mod:`.placements_png`, :mod:`.methods_png`, :mod:`.durations` and :mod:`.time_axis`; matplotlib is
imported only there). Nothing is imported here.
"""
