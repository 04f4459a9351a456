"""Effect families the discrepancy search fits, one small class each, all in one registry (`FAMILIES`).

Importing this package registers every family of its modules; a user's own family registers itself with
`twin.analysis.discrepancy.families.base.register` when its module is imported.
"""

from twin.analysis.discrepancy.families import robot, sensors, tracker
from twin.analysis.discrepancy.families.base import FAMILIES, Delta, Family, learns_from_run, register

__all__ = ["FAMILIES", "Delta", "Family", "learns_from_run", "register", "robot", "sensors", "tracker"]
