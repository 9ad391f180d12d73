"""Actors inside MRSS components: the Robot Communication Layer (rcl, robot, skill)."""
