"""Score predicted viewpoints against a dataset's sampled viewpoint quality.

One module per question asked of a prediction:

``scores``
    One direction per model and measure: the normalised quality of the
    nearest sampled view (the authors' protocol), per category and measure;
    the predictions files it reads.
``baselines``
    Random, PCA and oracle directions to compare a network with.
``coverage``
    ``k`` directions per model: the surface they show, against the greedy
    coverage set.
``protocol``
    A predictor scored on rotated inputs, the baselines under the same
    protocol, standard errors and paired differences.

``scores`` and ``coverage`` read predictions alike through the private
``_inputs`` (splits, prediction arrays, messages).

Import each name from its module (``from vptoolkit.evaluate.scores import
score_directions``); this package imports nothing. Numpy only (plus the
store's zarr or h5py); never torch, open3d or pymeshlab at import.
"""
