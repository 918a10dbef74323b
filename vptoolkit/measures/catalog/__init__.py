"""The catalog of viewpoint quality measures: one module per measure, listed here in order.

Each public module declares one :class:`~vptoolkit.measures.measure.Measure`
as its attribute ``MEASURE``; modules whose name starts with an underscore
hold what several measures share. :data:`CATALOG` lists every measure
explicitly, by family (:data:`~vptoolkit.measures.measure.FAMILIES`) and
within a family in the order ``--measures all`` gives them; the registry
(:mod:`vptoolkit.measures.registry`) reads it and nothing else. Adding a
measure is one module here and one entry of :data:`CATALOG`.
"""

from __future__ import annotations

from typing import Final

from vptoolkit.measures.catalog import (
    ce,
    dd,
    dvs,
    evmi,
    hm,
    i2,
    i3,
    ins,
    md,
    ms,
    nvt,
    pa,
    sal,
    sc,
    sce,
    se,
    sl,
    ss,
    ve,
    vkl,
    vmi,
    vr,
)
from vptoolkit.measures.measure import Measure

__all__ = ["CATALOG"]

CATALOG: Final[tuple[Measure, ...]] = (
    # area
    nvt.MEASURE, pa.MEASURE, hm.MEASURE, vr.MEASURE, ve.MEASURE, vkl.MEASURE,
    # information
    vmi.MEASURE, i2.MEASURE, i3.MEASURE,
    # silhouette
    sl.MEASURE, se.MEASURE, sc.MEASURE, sce.MEASURE,
    # depth
    md.MEASURE, dd.MEASURE, ss.MEASURE,
    # stability
    ins.MEASURE, dvs.MEASURE,
    # surface
    ce.MEASURE, sal.MEASURE, evmi.MEASURE, ms.MEASURE,
)
"""Every measure, by family and then in the order ``--measures all`` lists them."""
