"""Demonstrations in from standard robot-learning datasets, roll-outs out as such datasets.

Two formats, each read and written with pyarrow/json or h5py alone (their own libraries are not
needed; the tests prove that those libraries read what is written here, and that what they
write is read here):

- LeRobotDataset v3 (:mod:`.lerobot`): ``meta/info.json``, ``meta/episodes/*/*.parquet``,
  ``meta/tasks.parquet``, ``meta/stats.json`` and the frames in ``data/*/*.parquet``.
- Minari (:mod:`.minari`): ``<datasets root>/<dataset id>/data/metadata.json`` and
  ``main_data.hdf5`` (one HDF5 group per episode).

Reading gives :class:`~.episodes.DatasetEpisodes` (every numeric per-frame feature and
per-episode field of every episode); :func:`~.selection.select_demos` turns them into the
project's demonstration arrays by a :class:`~.selection.Selection` (which features are the
trajectory and the task parameters, which episodes, how time maps to the phase). Writing takes
:class:`~.episodes.RolloutEpisode` objects, one per roll-out.
"""
from .episodes import DatasetEpisodes, DatasetError, Episode, RolloutEpisode
from .selection import FeatureRef, Selection, TaskParamRef, select_demos

__all__ = ["DatasetEpisodes", "DatasetError", "Episode", "FeatureRef", "RolloutEpisode", "Selection",
           "TaskParamRef", "select_demos"]
