"""One module per viewpoint quality measure, each declaring ``MEASURE``.

:func:`vptoolkit.measures.registry.all_measures` finds every module here
whose name does not start with an underscore; modules that start with one
hold what several measures share.
"""
