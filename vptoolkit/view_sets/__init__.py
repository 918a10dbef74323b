"""Complementary view sets: k views that together show the whole model.

The paper predicts one view per measure and names complementary views as
future work ("a second view that best covers the unseen parts of the
model"). From the per-view, per-face pixel counts ``a_z(v)`` of
:mod:`vptoolkit.visibility` the brute-force answer is cheap: a greedy
search over the sampled views. Notation as in :mod:`vptoolkit.measures`:
``A_z`` the true area of face ``z``, ``A_t = sum_z A_z``, ``a_t(v) = sum_z
a_z(v)``, logarithms base 2.

Objectives (``objective=``)
    ``"coverage"``
        The area-weighted fraction of the surface seen by at least one view
        of the set ``S``:

        ``C(S) = sum_z A_z [max_{v in S} a_z(v) >= m] / A_t``

        with ``m = min_pixels`` (default 1). ``C`` is monotone and
        submodular (a weighted set cover), so the greedy choice, which adds
        the view of largest gain ``C(S + v) - C(S)``, reaches at least
        ``1 - (1 - 1/k)^k > 1 - 1/e ~ 0.632`` of the best k-set's coverage
        (Nemhauser, Wolsey and Fisher 1978); the tests compare it with
        exhaustive search. With ``m = 1`` a face counts as seen exactly when
        the paper's visibility ``vis_z(v) = [a_z(v) > 0]`` (eq. 2) holds, so
        ``C({v}) = VR(v)`` and the first pick is the best VR view. Why one
        pixel: the rasteriser counts a pixel only where the pixel *centre*
        lies inside the face (:mod:`vptoolkit.visibility`), so one pixel is
        a real sample of the face, never an anti-aliasing fringe; a larger
        threshold would drop every face smaller than it at the chosen
        resolution, making the coverage depend on the tessellation, and
        would break ``C({v}) = VR(v)``. Pass ``min_pixels`` to demand more
        (e.g. to ignore faces seen edge-on in a few pixels).
    ``"information"``
        The viewpoint entropy of the set, the entropy of the views' joint
        face distribution (Vazquez et al. 2003's entropy of a set of views;
        the channel of :mod:`vptoolkit.measures` restricted to ``S``):

        ``p_S(z) = sum_{v in S} a_z(v) / sum_{v in S} a_t(v)``,
        ``H(S) = -sum_z p_S(z) log2 p_S(z)``

        With ``p(v|S) = a_t(v) / sum_{u in S} a_t(u)`` it splits as
        ``H(S) = I(S; Z) + sum_{v in S} p(v|S) VE(v)``: the mutual
        information between the chosen views and the faces (high when the
        views see *different* faces) plus their mean entropy. ``H({v}) =
        VE(v)``, so the first pick is the best VE view. ``H`` is neither
        monotone nor submodular; greedy carries no guarantee here.
    ``"quality"``
        Coverage, preferring good single views among near-ties: the first
        pick is the best view of ``measure`` (default VE; with ``"VR"`` it is
        also the coverage objective's first pick), and every later pick is
        the view of highest normalised ``measure`` quality among those whose
        coverage gain is at least ``(1 - tolerance)`` times the largest gain.
        Each later gain is thus within ``alpha = 1 - tolerance`` of the
        greedy one, which gives ``C(S_k) >= (1 - (1 - alpha/k)^(k-1)) C*``
        for the best k-set's coverage ``C*``, whatever the first pick.

Sets are built in selection order; ``score[i]`` is the objective after pick
``i`` (a fraction for coverage and quality, bits for information) and
``coverage[i]`` the coverage ``C`` after pick ``i`` for every objective.
``k`` may be a number, or the set may grow until ``C(S) >= target *
C(V)``, where ``C(V)``, the *reachable* coverage, is that of all sampled
views together (faces inside the model are never seen): this answers the
paper's "the number of good views may vary per model". Ties go to the
lowest view index, so the same inputs give the same set.

Memory: the histograms of all views are kept (about 8 bytes per visible
face per view: 40 MB for 1000 views of a 10k-face mesh at 1024 px).

Modules: :mod:`~vptoolkit.view_sets.visibility` (the input, every view drawn
once), :mod:`~vptoolkit.view_sets.search` (the objectives and the greedy
search), :mod:`~vptoolkit.view_sets.result` (the chosen set and its files).
Import each name from its module (``from vptoolkit.view_sets.search import
best_view_set``); this package imports nothing.
"""
