"""Derivative-free optimisation: a particle swarm vectorised over the swarm."""

from skthermal.optimize._pso import particle_swarm

__all__ = ["particle_swarm"]
