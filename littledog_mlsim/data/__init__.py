"""Recorded moves: bags, the dataset index and split, the paper's state/feature extraction,
normalisation and path integration (``docs/interface.md`` §3 and §4).

Modules: ``recording`` (one move in memory), ``bags`` (one move as one bag), ``dataset`` (a
dataset directory: its index ``dataset.yaml``, split and loading), ``states`` (the paper's
state/feature extraction, path integration, normalisation), ``importer`` (recordings of any
origin into a dataset).

Public API: :class:`MoveRecording` (one move in memory); :func:`read_bag` / :func:`write_bag`
and :class:`BagError` (one move as one bag); :func:`read_index` / :func:`write_index`,
:func:`load_moves`, :class:`DatasetError` (a dataset directory and its TrainPool/TestPool);
:func:`states_from_recording`, :func:`actions_from_recording`, :func:`features_responses`
(the paper's Eq. 2); :func:`integrate_path`, :func:`initial_pose`; :class:`Normalizer`.
"""
from __future__ import annotations

from .bags import BagError, read_bag, write_bag
from .dataset import DatasetError, DatasetIndex, load_moves, read_index, write_index
from .recording import MoveRecording
from .states import (Normalizer, actions_from_recording, features_responses, initial_pose,
                     integrate_path, states_from_recording)

__all__ = ["MoveRecording", "BagError", "read_bag", "write_bag", "DatasetError", "DatasetIndex",
           "read_index", "write_index", "load_moves", "states_from_recording",
           "actions_from_recording", "features_responses", "integrate_path", "initial_pose",
           "Normalizer"]
