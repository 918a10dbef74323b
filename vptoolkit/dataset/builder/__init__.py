"""The resumable build of a store from a folder of meshes and point clouds.

Modules:

- ``run``: ``build_dataset``, the build with its failure log.
- ``options``: ``BuildOptions``, what defines a built dataset, checked when made.
- ``sources``: model files, names, ids, splits and seeds; ``staging``: the resumable
  staging folder; ``compute``: one model's task.
- ``plan``: the models a build would take, per category and split, and an
  estimate from a few calibration models.
- ``split_files``: published splits read from a ``name,split`` CSV or the
  paper's ``small.txt``.
"""
