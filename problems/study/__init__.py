"""Walking studies: walking steps solved over a grid of swept values, resumable, on a process
pool or a Dask cluster.

* :mod:`study`: the definition (``Study``) and its run;
* :mod:`point`: one point of the grid (its problem, solve, outputs);
* :mod:`schedule`: the order of the points (continuation neighbours);
* :mod:`runner`, :mod:`backends`: running the points (in process, pool, Dask);
* :mod:`store`: the study's folder (points, solutions, journal), safe against kill -9;
* :mod:`result`: the result read back, its grids and progress;
* :mod:`plots`: the study's pictures.

The command is :mod:`problems.cli.study`.
"""
