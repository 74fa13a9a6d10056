"""Task files: the schema's readers (one module per section), paths in time, and the task.

:func:`~forte.planning.tasks.tasks.load_task` reads a YAML file into a
:class:`~forte.planning.tasks.tasks.Task`; :mod:`~forte.planning.tasks.ik` turns its poses into
configurations (the initial guess) and :mod:`~forte.planning.tasks.posture` judges its start posture.
"""
