"""Ready-made mechanisms: the paper's impact slider–crank and a rotor hung in a bearing."""

from .rotor import rotor
from .xu2014 import TABLE5, TABLE5_TIMES, xu2014

__all__ = ["TABLE5", "TABLE5_TIMES", "rotor", "xu2014"]
