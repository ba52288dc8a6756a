"""hoprover: the hopping-rover problem of the 8th Spacecraft Control System Design
Contest (2015) as a fast, exact simulator and a Gymnasium environment."""
from .params import RoverParams
from .simulate import Rollout, RoverSim, simulate

__all__ = ["RoverParams", "Rollout", "RoverSim", "simulate"]
__version__ = "0.1.0"
