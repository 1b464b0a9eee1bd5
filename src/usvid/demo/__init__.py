"""usvid.demo: the whole chain on the bundled virtual Lanxin campaign (``usvid demo``).

:mod:`.campaign` generates the seeded virtual sea trials as real log files, :mod:`.pipeline`
reads, audits, identifies, validates and reports them, :mod:`.analysis` holds the validation,
course-keeping and turning-diameter sections of the report.
"""
