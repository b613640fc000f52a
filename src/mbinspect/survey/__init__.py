"""Whole surveys: many line files as one survey, read out of core into tiles and processed
tile by tile (in this process or on Dask), every object traced to the files and pings that
saw it.

1. ``inputs`` - :func:`expand_inputs` (files, folders, globs) and :func:`read_survey`
   (several files as one cloud, each sounding keeping its ``file``, ``line`` and ``ping``).
2. ``tiles`` - :func:`bin_file` (one file streamed in chunks into block-sorted parts on
   disk), :func:`choose_plan` (the tiles, whole blocks with a buffer, from the block
   counts) and :func:`load_tile` (a tile's blocks read back as one cloud).
3. ``run`` - :func:`~mbinspect.survey.run.run_survey`: in memory for a small survey,
   else binned, every tile processed on its own, objects kept by the tile holding their
   centre and merged once (reef numbers, pile groups and spacings formed after the merge).
4. ``cluster`` - the Dask client (a local cluster sized to the machine, or a scheduler's
   address) and the progress over tiles.
5. ``trace`` - :func:`sources`: the files and ping ranges behind an object.
"""

from ..cloud import ping_ranges, sources
from .inputs import expand_inputs, read_survey

__all__ = ["expand_inputs", "read_survey", "ping_ranges", "sources"]
