"""Neural inverse model: a set network from backbone fitting points to (kn, delta).

``points``: the flat point-set layout of many identification cases (:class:`PointSets`).
"""

from .points import PointSets, point_sets_from_records

__all__ = ["PointSets", "point_sets_from_records"]
