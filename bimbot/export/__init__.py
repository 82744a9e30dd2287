"""``bimbot export``: a run's answer written into the tools builders work in.

One module per format, pure functions first: :mod:`.run_data` reads a run (manifest, report, journal,
plan), :mod:`.sim_schedule` turns it into the simulated schedule (one task per component, its method's
steps, sim times, precedences, robots), and the writers put that schedule into a 4D IFC
(:mod:`.ifc_export`), MS Project and Primavera P6 XML (:mod:`.planner_files`, through ``ifc4d``) and a USD
stage (:mod:`.usd_stage`). :mod:`.cli` is the command.
"""
