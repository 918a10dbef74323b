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

Every public name is re-exported here, so ``from vptoolkit.evaluate import
score_directions`` works. Numpy only (plus the store's zarr or h5py);
never torch, open3d or pymeshlab at import.
"""

from vptoolkit.evaluate._inputs import EVALUATION_SPLITS
from vptoolkit.evaluate.baselines import oracle_directions, pca_directions, random_directions
from vptoolkit.evaluate.coverage import (
    ViewSetReport,
    evaluate_view_sets,
    model_view_set,
    model_visibility,
    score_view_sets,
    stored_view_set,
)
from vptoolkit.evaluate.protocol import (
    Predictor,
    ProtocolScores,
    best_constant_directions,
    constant_predictor,
    paired_difference,
    pca_predictor,
    random_view_scores,
    score_protocol,
)
from vptoolkit.evaluate.scores import (
    EvaluationReport,
    evaluate_predictions,
    load_predictions,
    save_predictions,
    score_directions,
)

__all__ = [
    "EVALUATION_SPLITS",
    "EvaluationReport",
    "load_predictions",
    "save_predictions",
    "score_directions",
    "evaluate_predictions",
    "random_directions",
    "pca_directions",
    "oracle_directions",
    "ViewSetReport",
    "score_view_sets",
    "evaluate_view_sets",
    "model_visibility",
    "model_view_set",
    "stored_view_set",
    "Predictor",
    "ProtocolScores",
    "score_protocol",
    "random_view_scores",
    "pca_predictor",
    "best_constant_directions",
    "constant_predictor",
    "paired_difference",
]
