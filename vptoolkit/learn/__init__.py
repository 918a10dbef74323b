"""Viewpoint learning with PyTorch (Schelling et al. 2021, sections 4 and 5).

Modules, one concept each (import them directly; this package imports
nothing, so ``import vptoolkit.learn`` never loads torch):

- ``vptoolkit.learn.model``: the point-cloud network: a hierarchy of voxel-grid
  point levels, Monte Carlo convolutions normalised by a point-density
  estimate, and one head per measure (unit direction, spherical regression or
  a 32 x 32 sphere map); :func:`~vptoolkit.learn.model.save_model` and
  :func:`~vptoolkit.learn.model.load_model` (safetensors + JSON, no pickle).
- ``vptoolkit.learn.labels``: the label methods and their losses: single
  label (SL), multiple labels (ML), Gaussian labels (GL), ML+GL, spherical
  regression (SR) and label distribution learning (DLDL), plus the
  nearest-view quality used to score predictions.
- ``vptoolkit.learn.options``: :class:`~vptoolkit.learn.options.TrainOptions`,
  what defines a training run, as one checked value.
- ``vptoolkit.learn.train``: :func:`~vptoolkit.learn.train.train_model`, the
  training loop (Adam, step decay, validation, best checkpoint, resume).
- ``vptoolkit.learn.predict``: :func:`~vptoolkit.learn.predict.predict` on
  meshes, point files or a dataset split (read through
  :func:`vptoolkit.inputs.open_inputs`), returning
  :class:`~vptoolkit.predictions.Predictions`; ``vptoolkit.learn.consensus``:
  one answer from the network's answers to several inputs of a model;
  ``vptoolkit.learn.draws``: which points those inputs are, seeded by the
  points' content (numpy only).
- ``vptoolkit.learn.config``: ``ModelConfig`` and ``LevelConfig``, the
  architecture as data (no torch); ``vptoolkit.learn.hierarchy`` and
  ``vptoolkit.learn.layers``: the point hierarchy (grid levels,
  neighbourhoods, densities) and the layers (Monte Carlo convolution, encoder,
  heads); ``vptoolkit.learn.frame``: the canonical input frame;
  ``vptoolkit.learn.octahedral``: the octahedral sphere grid of the DLDL maps.
- ``vptoolkit.learn.checkpoint``: checkpoint files (safetensors + JSON), read
  and written safely; ``vptoolkit.learn.record``: the training record a
  checkpoint's ``model.json`` carries; ``vptoolkit.learn.state``: the
  resumable state of a run (weights, Adam moments, history), without pickle.
- ``vptoolkit.learn.schedule``: the paper's optimisation settings and its
  learning-rate schedule; ``vptoolkit.learn.splits``: which models of a store
  a run uses; ``vptoolkit.learn.validation``: validation during training,
  under the rotated protocol.
- ``vptoolkit.learn.prior``: a network as the prior of the best-view search.

Everything here needs the ``learn`` extra: ``pip install 'vptoolkit[learn]'``
(torch and safetensors).
"""
