"""The observer: the live digital twin in rerun, the construction report, and a terminal table.

* :mod:`.twin_log` — pure: bus messages → rerun archetypes at entity paths (colours by state as a table);
* :mod:`.blueprint` — the viewer layout (3D view, progress plots, text log);
* the end-of-run report when it runs on its own: :mod:`bimbot.shared.report`;
* :mod:`.app` / :mod:`.cli` — ``bimbot observe``: the Zenoh adapter, rerun sinks and the web viewer;
* :mod:`.watch` — ``bimbot watch``: a live table of component states in the terminal.
"""

# The ports the observer serves the web viewer and its data on, unless told otherwise: the one default that
# ObserverConfig, ``bimbot run --live`` and ``bimbot observe`` take (this package stays free of imports).
VIEWER_WEB_PORT = 9090
VIEWER_GRPC_PORT = 9876
