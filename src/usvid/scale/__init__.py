"""Scale-out on Dask (``dask.distributed``): Monte-Carlo simulation over parameter uncertainty
(:mod:`usvid.scale.montecarlo`) and campaigns of many logs (:mod:`usvid.scale.batch`).

Work is cut into independent tasks (chunks of runs, groups of logs) submitted to a Dask client:
a :class:`distributed.LocalCluster` on this machine by default, or an existing cluster by its
scheduler address (:mod:`usvid.scale.cluster`). Results do not depend on the number of workers
or on the chunking.
"""
